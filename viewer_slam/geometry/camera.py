"""Pinhole camera with the TUM depth convention."""

import json
from dataclasses import asdict, dataclass, field, replace
from functools import cache
from pathlib import Path
from typing import TYPE_CHECKING, Annotated, Any

import numpy as np

from ..documents import read_json
from ..errors import InputError

if TYPE_CHECKING:
    import pydantic

TUM_DEPTH_FACTOR = 5000.0
# The image sizes a sequence may have, pixels a side (a budget checked before any image is decoded).
MIN_SIDE, MAX_SIDE = 16, 8192
# Focal lengths, principal point offsets and distortion coefficients beyond these are no lens.
MAX_FOCAL_PX = 1e6
MAX_DISTORTION = 1e3
CALIBRATION_BYTES = 2**20
"""camera.json holds a dozen numbers: a file larger than this is no calibration."""


@dataclass(frozen=True)
class Camera:
    """Intrinsics of the RGB optical frame (x right, y down, z forward).

    ``depth_factor`` converts the stored uint16 depth to metres (TUM: 5000 per metre).
    ``distortion`` holds OpenCV's ``(k1, k2, p1, p2, k3)``; the registered TUM depth and
    colour images are used as they are, so pipelines treat the images as undistorted.
    """

    fx: float
    fy: float
    cx: float
    cy: float
    width: int
    height: int
    depth_factor: float = TUM_DEPTH_FACTOR
    distortion: tuple[float, ...] = field(default=(0.0, 0.0, 0.0, 0.0, 0.0))

    @property
    def K(self) -> np.ndarray:
        return np.array([[self.fx, 0, self.cx], [0, self.fy, self.cy], [0, 0, 1]], dtype=np.float64)

    def scaled(self, width: int, height: int) -> "Camera":
        """The same lens at another resolution (pixel-centre convention kept)."""
        sx, sy = width / self.width, height / self.height
        return replace(
            self,
            fx=self.fx * sx,
            fy=self.fy * sy,
            cx=(self.cx + 0.5) * sx - 0.5,
            cy=(self.cy + 0.5) * sy - 0.5,
            width=width,
            height=height,
        )

    def backproject(self, uv: np.ndarray, depth: np.ndarray) -> np.ndarray:
        """3D points ``(N, 3)`` in the camera frame from pixels ``(N, 2)`` and depths ``(N,)``."""
        z = np.asarray(depth, dtype=np.float64)
        x = (uv[:, 0] - self.cx) / self.fx * z
        y = (uv[:, 1] - self.cy) / self.fy * z
        return np.stack([x, y, z], axis=1)

    def project(self, points: np.ndarray) -> np.ndarray:
        """Pixels ``(N, 2)`` of camera-frame points ``(N, 3)`` (z must be positive)."""
        z = points[:, 2]
        return np.stack([self.fx * points[:, 0] / z + self.cx, self.fy * points[:, 1] / z + self.cy], axis=1)

    def depth_to_points(self, depth: np.ndarray, step: int = 1) -> tuple[np.ndarray, np.ndarray]:
        """Points ``(N, 3)`` of every ``step``-th pixel with valid depth, and their ``(row, col)``."""
        rows, cols = np.mgrid[0 : depth.shape[0] : step, 0 : depth.shape[1] : step]
        z = depth[rows, cols]
        valid = z > 0
        rows, cols, z = rows[valid], cols[valid], z[valid]
        uv = np.stack([cols, rows], axis=1).astype(np.float64)
        return self.backproject(uv, z), np.stack([rows, cols], axis=1)

    def to_json(self) -> dict[str, Any]:
        data = asdict(self)
        data["distortion"] = list(self.distortion)
        return data

    def save(self, path: Path) -> None:
        Path(path).write_text(json.dumps(self.to_json(), indent=2) + "\n")

    @classmethod
    def load(cls, path: Path) -> "Camera":
        """Read ``camera.json`` (fx, fy, cx, cy, width, height, depth_factor, distortion), checked."""
        return cls.checked(read_json(path, "camera calibration", max_bytes=CALIBRATION_BYTES), path)

    @classmethod
    def checked(cls, data: Any, where: Path | str) -> "Camera":
        """A camera from ``data`` (the keys of camera.json), every value checked to be one a lens can
        have; :class:`InputError` naming ``where`` otherwise."""
        import pydantic  # only where a calibration is read: it adds to every command's start-up

        try:
            checked = _camera_schema().model_validate(data)
        except pydantic.ValidationError as error:
            raise InputError.at(where, _problem(error)) from None
        return cls(**checked.model_dump())


def _problem(error: "pydantic.ValidationError") -> str:
    """The missing keys, else ``FIELD must be ..., got VALUE`` for the first problem of a pydantic
    ValidationError."""
    missing = [str(detail["loc"][0]) for detail in error.errors() if detail["type"] == "missing"]
    if missing:
        return f"camera calibration lacks {', '.join(missing)}"
    detail = error.errors()[0]
    if detail["type"] == "model_type":
        return (
            f"bad camera calibration: expected a JSON object with fx, fy, cx, cy, width, height, "
            f"got {detail['input']!r}"
        )
    if not detail["loc"]:  # a rule between fields, whose message says it all
        return f"bad camera calibration: {detail['msg'].removeprefix('Value error, ')}"
    where = ".".join(map(str, detail["loc"]))
    return (
        f"bad camera calibration: {where} {detail['msg'].replace('Input should be', 'must be')}, "
        f"got {detail['input']!r}"
    )


@cache
def _camera_schema() -> type["pydantic.BaseModel"]:
    """The schema of camera.json: focal lengths of a lens, the principal point within the image,
    a size within the image budget, a depth unit of at most a metre, finite numbers throughout."""
    import pydantic

    focal = Annotated[float, pydantic.Field(gt=0, le=MAX_FOCAL_PX, allow_inf_nan=False)]
    offset = Annotated[float, pydantic.Field(allow_inf_nan=False)]
    pixels = Annotated[int, pydantic.Field(ge=MIN_SIDE, le=MAX_SIDE)]
    coefficient = Annotated[float, pydantic.Field(ge=-MAX_DISTORTION, le=MAX_DISTORTION, allow_inf_nan=False)]
    per_metre = Annotated[float, pydantic.Field(ge=1, le=1e6, allow_inf_nan=False)]

    def principal_point(camera: Any) -> Any:
        for axis, size in (("cx", camera.width), ("cy", camera.height)):
            if not 0 <= getattr(camera, axis) <= size:
                raise ValueError(f"{axis} must lie within the image (0 to {size}), got {getattr(camera, axis)!r}")
        return camera

    return pydantic.create_model(
        "CameraFile",
        __config__=pydantic.ConfigDict(extra="ignore"),
        # pydantic's annotation asks for plain functions, though it documents decorated ones here.
        __validators__={"principal_point": pydantic.model_validator(mode="after")(principal_point)},  # type: ignore[dict-item]
        fx=(focal, ...),
        fy=(focal, ...),
        cx=(offset, ...),
        cy=(offset, ...),
        width=(pixels, ...),
        height=(pixels, ...),
        depth_factor=(per_metre, TUM_DEPTH_FACTOR),
        distortion=(tuple[coefficient, ...], (0.0,) * 5),
    )
