"""neuroom: understand a known room from one 360° panorama and render it from anywhere.

A room's trained models (``Models``) locate the camera and every object of a panorama
(``Models.locate``), refine them with the holistic fit (``Models.fit``), render the room as an
arrangement places it from its panorama camera or any ``Pinhole`` (``Models.render``) and edit
arrangements (``Models.edit``); ``evaluate`` scores arrangements against a room's ground truth.
Long calls release the interpreter, report progress through a callback or a ``tqdm`` bar and stop
on Ctrl-C; failures raise ``NeuroomError`` naming the file and the problem.
"""

from ._neuroom import (
    Arrangement,
    Models,
    NeuroomError,
    Pinhole,
    PlacedObject,
    RenderedImage,
    Room,
    evaluate,
    read_image,
)

__all__ = [
    "Arrangement",
    "Models",
    "NeuroomError",
    "Pinhole",
    "PlacedObject",
    "RenderedImage",
    "Room",
    "evaluate",
    "read_image",
]
