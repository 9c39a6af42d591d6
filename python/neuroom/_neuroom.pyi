"""Type stubs of the extension module (crates/neuroom-py)."""

import os
import pathlib
from typing import Any, Callable, Sequence, TypedDict, Union

import numpy as np
import numpy.typing as npt

PathLike = Union[str, os.PathLike[str]]
ImageInput = Union[PathLike, npt.NDArray[np.uint8], npt.NDArray[np.float32], npt.NDArray[np.float64]]
Progress = Union[Callable[[str, int, int], object], Any]
Matrix4 = Union[npt.NDArray[np.floating[Any]], Sequence[Sequence[float]]]
Vector3 = Union[npt.NDArray[np.floating[Any]], Sequence[float]]

class NeuroomError(Exception):
    """A neuroom pipeline failed: the message names the file and the problem."""

class RoomObject(TypedDict):
    id: int
    name: str
    category: str
    size: tuple[float, float, float]

class Room:
    """A room folder: room.json, its captures and its test panoramas."""

    def __init__(self, path: PathLike) -> None: ...
    @property
    def path(self) -> pathlib.Path: ...
    @property
    def name(self) -> str: ...
    @property
    def objects(self) -> list[RoomObject]: ...
    @property
    def model_names(self) -> list[str]:
        """The models the room needs, `background` first: what `Models.train(only=...)` takes."""
    def test_panoramas(self) -> list[tuple[pathlib.Path, Arrangement]]:
        """The test panoramas with their ground-truth arrangements."""

class PlacedObject:
    """One placed object of an arrangement."""

    @property
    def id(self) -> int: ...
    @property
    def name(self) -> str: ...
    @property
    def pose(self) -> npt.NDArray[np.float64]:
        """Object to world, 4×4."""
    @property
    def size(self) -> tuple[float, float, float] | None:
        """Full box extents in the object's frame (metres), when the room is known."""
    @property
    def score(self) -> float | None:
        """Locate's score, when the arrangement records one."""

class Arrangement:
    """The panorama's camera and the objects placed in the room (docs/formats.md)."""

    @staticmethod
    def from_json(text: str, room: Room | PathLike | None = None) -> Arrangement: ...
    @staticmethod
    def read(path: PathLike, room: Room | PathLike | None = None) -> Arrangement: ...
    def to_json(self) -> str: ...
    def write(self, path: PathLike) -> None: ...
    @property
    def image(self) -> str: ...
    @property
    def camera_to_world(self) -> npt.NDArray[np.float64]:
        """The panorama camera, 4×4 (+x the centre column, +y left, +z up)."""
    @property
    def objects(self) -> list[PlacedObject]: ...
    @property
    def camera_confidence(self) -> float | None: ...
    @property
    def warnings(self) -> list[str]: ...
    def __len__(self) -> int: ...

class Pinhole:
    """A pinhole camera; `camera_to_world` in the OpenGL / nerfstudio frame (looks along −z, +y up)."""

    def __init__(
        self,
        fx: float,
        fy: float,
        cx: float,
        cy: float,
        width: int,
        height: int,
        camera_to_world: Matrix4,
    ) -> None: ...
    @staticmethod
    def looking_at(
        eye: Vector3,
        target: Vector3,
        width: int = 640,
        height: int = 480,
        fov_deg: float = 60.0,
    ) -> Pinhole:
        """A camera at `eye` looking at `target` (world metres, z up), horizontal field of view `fov_deg`."""
    @property
    def camera_to_world(self) -> npt.NDArray[np.float64]: ...
    @property
    def fx(self) -> float: ...
    @property
    def fy(self) -> float: ...
    @property
    def cx(self) -> float: ...
    @property
    def cy(self) -> float: ...
    @property
    def width(self) -> int: ...
    @property
    def height(self) -> int: ...

class RenderedImage:
    """A render: colour, depth and instance ids."""

    @property
    def rgb(self) -> npt.NDArray[np.float32]:
        """H×W×3, sRGB in [0, 1]."""
    @property
    def depth(self) -> npt.NDArray[np.float32]:
        """H×W metres, 0 where nothing was hit."""
    @property
    def instance(self) -> npt.NDArray[np.uint16]:
        """H×W object ids, 0 for the room."""

class Models:
    """A room's trained models (`<out>/<room name>`)."""

    @staticmethod
    def train(
        room: Room | PathLike,
        out: PathLike,
        steps: int | None = None,
        background_steps: int | None = None,
        progress: Progress | None = None,
        only: Sequence[str] | None = None,
        threads: int = 0,
        seed: int | None = None,
    ) -> Models: ...
    @staticmethod
    def open(path: PathLike, room: Room | PathLike | None = None) -> Models: ...
    @property
    def path(self) -> pathlib.Path: ...
    @property
    def room(self) -> Room: ...
    @property
    def names(self) -> list[str]: ...
    @property
    def complete(self) -> bool: ...
    def locate(
        self, image: ImageInput, name: str | None = None, progress: Progress | None = None
    ) -> Arrangement: ...
    def fit(
        self,
        image: ImageInput,
        initial: Arrangement,
        pose_iterations: int | None = None,
        appearance_iterations: int | None = None,
        progress: Progress | None = None,
    ) -> Arrangement: ...
    def render(
        self,
        arrangement: Arrangement,
        camera: Pinhole | None = None,
        width: int = 512,
        progress: Progress | None = None,
    ) -> RenderedImage: ...
    def edit(
        self, arrangement: Arrangement, edits: Sequence[dict[str, Any]], settle: bool = True
    ) -> Arrangement: ...

def evaluate(
    room: Room | PathLike,
    arrangements: Sequence[Arrangement | PathLike],
    models: Models | PathLike | None = None,
    render_width: int = 512,
    progress: Progress | None = None,
) -> dict[str, Any]: ...

def read_image(path: PathLike) -> npt.NDArray[np.float32]:
    """An image file as H×W×3 sRGB values in [0, 1], as the pipelines read it."""
