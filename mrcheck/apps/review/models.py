"""The request bodies of the review's API (pydantic, strict)."""

from __future__ import annotations

from typing import Literal

from pydantic import BaseModel, ConfigDict, Field

from mrcheck.apps.review.bcf import MAX_FIELD
from mrcheck.apps.review.storage import CATEGORIES, MAX_NOTE
from mrcheck.render.renderer import MODES

Category = Literal["missing", "moved", "extra", "wrong size", "other", "suggested"]
assert set(Category.__args__) == set(CATEGORIES)
Mode = Literal[MODES]
# strict: a field of the wrong type (a severity true or "2", a note null) or an unknown one (a
# typo such as "severty") is a 422, not converted or ignored; a whole number is still a valid x
_STRICT = ConfigDict(extra="forbid", strict=True)


class MarkerIn(BaseModel):
    model_config = _STRICT
    shot: str = Field(max_length=128)
    x: float
    y: float
    category: Category
    severity: int = Field(ge=1, le=3)
    note: str = Field(default="", max_length=MAX_NOTE)
    mode: Mode | None = None  # the mode the marker was placed in


class MarkerPatch(BaseModel):
    """Only the fields given are changed (the None defaults mean "not given"; null is refused)."""

    model_config = _STRICT
    x: float = None
    y: float = None
    category: Category = None
    severity: int = Field(default=None, ge=1, le=3)
    note: str = Field(default=None, max_length=MAX_NOTE)
    mode: Mode = None
    status: str = Field(default=None, min_length=1, max_length=MAX_FIELD)  # BCF TopicStatus: free text


class CommentIn(BaseModel):
    """A comment written in the review's marker editor (author: the review's ``--author``)."""

    model_config = _STRICT
    text: str = Field(min_length=1, max_length=MAX_NOTE)


class OffsetIn(BaseModel):
    """The pixel (the shot's photo pixels, as a marker's) of the CAD point that should be where
    the marker is: the marker's offset is measured from it (:mod:`.measure`)."""

    model_config = _STRICT
    x: float
    y: float
