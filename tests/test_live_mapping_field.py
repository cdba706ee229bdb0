"""The Infer tab's LSL mapping field (``app.panels.infer.live_section.GuessedText``): the studio
fills it with a guess from the streams found until the user edits it, and never writes a guess
over what the user typed, even when viser has set the page's value but not yet run the field's
``on_update`` (it runs callbacks later, on its thread pool). The page's flow (typed, refused,
typed again, started) is ``tests/test_live_streams_in_studio.py``'s."""

from __future__ import annotations

from app.panels.infer.live_section import GuessedText


class Field:
    """A viser text handle's value, as the server holds it."""

    def __init__(self, value: str = "") -> None:
        self.value = value
        self.writes = 0

    def __setattr__(self, name, value) -> None:
        if name == "value":
            object.__setattr__(self, "writes", getattr(self, "writes", 0) + 1)
        object.__setattr__(self, name, value)


def test_the_guess_follows_the_streams_found_until_the_user_edits() -> None:
    field = Field()
    text = GuessedText(field)
    assert not text.edited
    text.offer("hand=A:0,1,2")
    assert field.value == "hand=A:0,1,2" and not text.edited
    text.offer("hand=B:0,1,2")  # the streams found changed: a new guess
    assert field.value == "hand=B:0,1,2" and not text.edited
    writes = field.writes
    text.offer("hand=B:0,1,2")  # the same guess: nothing sent to the page
    assert field.writes == writes


def test_a_value_typed_before_its_callback_runs_is_not_overwritten() -> None:
    field = Field()
    text = GuessedText(field)
    text.offer("hand=A:0,1,2")
    field.value = "hand=A:0,1"  # the page's message, its on_update not run yet
    text.offer("hand=B:0,1,2")  # the frame loop's next guess, in between
    assert field.value == "hand=A:0,1" and text.edited
    text.typed()  # the callback, late
    text.offer("hand=C:0,1,2")
    assert field.value == "hand=A:0,1"


def test_typing_the_guess_back_keeps_the_users_choice() -> None:
    field = Field()
    text = GuessedText(field)
    text.offer("hand=A:0,1,2")
    field.value = "hand=A:0,1"
    assert text.edited
    field.value = "hand=A:0,1,2"  # typed back to the guess: still the user's text
    text.offer("hand=B:0,1,2")
    assert field.value == "hand=A:0,1,2"


def test_a_callback_alone_marks_the_field_edited() -> None:
    field = Field()
    text = GuessedText(field)
    text.offer("hand=A:0,1,2")
    text.typed()  # a page's update whose value was the guess already
    text.offer("hand=B:0,1,2")
    assert field.value == "hand=A:0,1,2"


def test_guess_and_a_new_layout_write_over_the_edit_and_guessing_resumes() -> None:
    field = Field()
    text = GuessedText(field)
    text.offer("hand=A:0,1,2")
    field.value = "typed"
    text.typed()
    text.reset("hand=B:0,1,2")  # *Guess the mapping* pressed, or the workspace's layout changed
    assert field.value == "hand=B:0,1,2" and not text.edited
    text.offer("hand=C:0,1,2")
    assert field.value == "hand=C:0,1,2"
