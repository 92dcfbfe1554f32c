"""The printed ChArUco board a camera is calibrated with (recorder/wrist/calibration.py): ``BoardSpec``, its
layout, sizes, dictionary and OpenCV's legacy pattern, given as flags or a YAML file (keys: the fields), and the
printable board at its true size (`gloverec board`: a PDF page or a PNG at a stated dpi)."""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path
from typing import Annotated

import annotated_types as at
import cv2
import numpy as np

from recorder.config import STRICT, ConfigError, load
from recorder.wrist.marker import DICTIONARIES

MM_PER_INCH = 25.4


@dataclass(frozen=True)
class BoardSpec:
    """The printed ChArUco board: squares across and down, the squares' and markers' sides (m), the dictionary,
    and OpenCV's legacy pattern (boards made before OpenCV 4.6, or by other tools, with an even number of rows:
    the top-left square is white; ``cv2.aruco.CharucoBoard.setLegacyPattern``)."""

    __pydantic_config__ = STRICT

    squares: tuple[Annotated[int, at.Ge(2)], Annotated[int, at.Ge(2)]] = (7, 5)
    square_m: Annotated[float, at.Gt(0)] = 0.03
    marker_m: Annotated[float, at.Gt(0)] = 0.022
    dictionary: str = "4X4_50"
    legacy: bool = False

    def __post_init__(self):
        if self.dictionary not in DICTIONARIES:
            raise ConfigError(f"unknown board dictionary {self.dictionary!r}; valid: {', '.join(DICTIONARIES)}")
        if not 0 < self.marker_m < self.square_m:
            raise ConfigError(f"the board's markers ({self.marker_m * 1e3:g} mm) must be smaller than its squares "
                              f"({self.square_m * 1e3:g} mm)")  # fmt: skip
        if min(self.squares) < 2:
            raise ConfigError(f"a ChArUco board has 2 or more squares each way, not {self.layout()}")
        held = cv2.aruco.getPredefinedDictionary(DICTIONARIES[self.dictionary]).bytesList.shape[0]
        if self.markers() > held:
            raise ConfigError(f"a {self.layout()} board has {self.markers()} markers: more than {self.dictionary} "
                              f"holds ({held})")  # fmt: skip

    def board(self):
        aruco = cv2.aruco.getPredefinedDictionary(DICTIONARIES[self.dictionary])
        board = cv2.aruco.CharucoBoard(self.squares, self.square_m, self.marker_m, aruco)
        board.setLegacyPattern(self.legacy)
        return board

    def image(self, px_per_square: int = 80) -> np.ndarray:
        return self.board().generateImage((self.squares[0] * px_per_square, self.squares[1] * px_per_square))

    def size_m(self) -> tuple[float, float]:
        return self.squares[0] * self.square_m, self.squares[1] * self.square_m

    def markers(self) -> int:
        return self.squares[0] * self.squares[1] // 2

    def layout(self) -> str:
        return f"{self.squares[0]}×{self.squares[1]}"

    def caption(self) -> str:
        return (f"ChArUco {self.layout()} squares of {self.square_m * 1e3:g} mm, markers {self.marker_m * 1e3:g} mm, "
                f"{self.dictionary}{', legacy pattern' if self.legacy else ''}: print at 100 % and check that a "
                f"square measures {self.square_m * 1e3:g} mm")  # fmt: skip


def layout(text: str) -> tuple[int, int]:
    """``"5x7"`` (squares across x down; ``×`` or ``X`` also) -> (5, 7); ValueError otherwise."""
    m = re.fullmatch(r"\s*(\d+)\s*[xX×]\s*(\d+)\s*", text)
    if m is None or min(int(m[1]), int(m[2])) < 2:
        raise ValueError(f"expected the board's squares across x down, e.g. 5x7, got {text!r}")
    return int(m[1]), int(m[2])


def board_spec(path: str | Path | None = None, **overrides) -> BoardSpec:
    """BoardSpec's defaults, then the YAML file ``path`` (keys: its fields), then ``overrides`` (None: kept);
    ConfigError in one line naming the file and key."""
    if path is None:  # flags alone: typed by argparse, checked by BoardSpec
        return BoardSpec(**{k: v for k, v in overrides.items() if v is not None})
    return load(BoardSpec, path, overrides=overrides)


def save_printable(board: BoardSpec, path: str | Path, dpi: int = 300, margin_mm: float = 10.0) -> tuple[float, float]:
    """The board at its true size with a white margin and a caption in it: a PDF page (the board's size plus the
    margins, the image placed at its size in mm) or a PNG at ``dpi`` (the dpi recorded in the file). Returns the
    PNG's pixels or the PDF page's points (1/72 inch), (width, height)."""
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix not in (".pdf", ".png"):
        raise ConfigError(f"{path}: the printable board is a .pdf or a .png")
    if not path.parent.is_dir():
        raise ConfigError(f"{path}: no such folder {path.parent}")
    w_mm, h_mm = (v * 1e3 for v in board.size_m())
    px_per_square = max(1, round(board.square_m * 1e3 / MM_PER_INCH * dpi))
    image = board.image(px_per_square)
    if suffix == ".png":
        return _save_png(board, image, path, dpi, round(margin_mm / MM_PER_INCH * dpi))
    return _save_pdf(board, image, path, (w_mm, h_mm), margin_mm)


def _save_png(board: BoardSpec, image: np.ndarray, path: Path, dpi: int, pad: int) -> tuple[int, int]:
    from PIL import Image, ImageDraw, ImageFont  # matplotlib's dependency; it writes the dpi, cv2.imwrite does not

    page = Image.fromarray(cv2.copyMakeBorder(image, pad, pad, pad, pad, cv2.BORDER_CONSTANT, value=255))
    size = pad // 3  # the caption in the bottom margin, as wide as the board at most
    if size >= 8:
        font = ImageFont.load_default(size)
        draw, caption = ImageDraw.Draw(page), board.caption().replace("×", "x")  # the default font's letters
        size = min(size, int(size * image.shape[1] / max(1.0, draw.textlength(caption, font=font))))
        draw.text((pad, page.height - pad // 2), caption, fill=0, font=ImageFont.load_default(size), anchor="lm")
    try:
        page.save(path, dpi=(dpi, dpi))
    except OSError as exc:
        raise ConfigError(f"cannot write {path}: {exc.strerror or exc}") from None
    return page.size


def _save_pdf(board, image, path: Path, size_mm: tuple[float, float], margin_mm: float) -> tuple[float, float]:
    from matplotlib.figure import Figure  # not pyplot: no GUI backend, no global state

    page_mm = size_mm[0] + 2 * margin_mm, size_mm[1] + 2 * margin_mm
    fig = Figure(figsize=(page_mm[0] / MM_PER_INCH, page_mm[1] / MM_PER_INCH))
    ax = fig.add_axes((margin_mm / page_mm[0], margin_mm / page_mm[1], size_mm[0] / page_mm[0],
                       size_mm[1] / page_mm[1]))  # fmt: skip
    ax.imshow(image, cmap="gray", vmin=0, vmax=255, interpolation="none", aspect="auto")  # "none": embedded as is
    ax.set_axis_off()
    fig.text(0.5, margin_mm / 3 / page_mm[1], board.caption(), ha="center", va="center", fontsize=7, wrap=True)
    try:
        fig.savefig(path, format="pdf")
    except OSError as exc:
        raise ConfigError(f"cannot write {path}: {exc.strerror or exc}") from None
    return page_mm[0] / MM_PER_INCH * 72, page_mm[1] / MM_PER_INCH * 72


def film_board(path: str | Path, board: BoardSpec = BoardSpec(), views: int = 14, seed: int = 1):
    """A rendered webcam's lossless video (FFV1: .mkv) of ``board`` moved through its view, 0.35 to 0.6 m away and
    tilted 10 to 40°, one view a frame (tests, benchmarks); returns the camera's true CameraModel."""
    from recorder import quat
    from recorder.wrist.marker import PlateScene  # MuJoCo: the rendered scene only

    scene = PlateScene(board.image(), board.size_m())
    rng = np.random.default_rng(seed)
    face = quat.from_two_vectors(np.array([0.0, 0, 1]), np.array([-1.0, 0, 0]))  # the plate faces the camera
    positions, quats = [], []
    for _ in range(views):
        positions.append([rng.uniform(0.35, 0.6), rng.uniform(-0.05, 0.05), rng.uniform(-0.04, 0.04)])
        axis = np.array([0.0, *rng.normal(size=2)])
        tilt = quat.from_axis_angle(axis / np.linalg.norm(axis), np.radians(rng.uniform(10, 40)))
        quats.append(quat.mul(tilt, face))
    try:
        scene.record(path, positions, quats)
    finally:
        scene.close()
    return scene.camera
