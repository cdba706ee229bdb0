"""The iCub intention studio: a viser web app over ``promp`` and ``robots.icub``."""
