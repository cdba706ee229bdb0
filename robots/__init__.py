"""Robots the studio can drive. Only the iCub for now (``robots.icub``)."""
