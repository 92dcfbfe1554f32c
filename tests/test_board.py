"""The calibration board the user owns (recorder/wrist/board.py, board_hint.py): `gloverec calibrate --camera`
takes the board's layout, sizes, dictionary and legacy pattern as flags or a YAML file, names the board the views
show when it is not the one described, and `gloverec board` writes the printable board at its true size."""

import json
import re

import numpy as np
import pytest

from conftest import cli


@pytest.fixture(scope="module")
def tutorial_board(tmp_path_factory):
    """A rendered webcam's video of OpenCV's tutorial board (5 × 7 squares of 30 mm, 22 mm markers, 4X4_50), and
    the camera's true model."""
    from recorder.wrist.board import BoardSpec, film_board

    path = tmp_path_factory.mktemp("board") / "board57.mkv"
    truth = film_board(path, BoardSpec(squares=(5, 7)), views=10)
    return path, truth


def test_a_5x7_board_calibrates_with_board_5x7_and_without_it_the_error_names_5x7(tutorial_board, tmp_path):
    video, truth = tutorial_board
    r = cli("calibrate", "--camera", str(video), "--dir", str(tmp_path))
    assert r.returncode == 1 and r.stderr.count("\n") == 1, r.stderr
    assert "found 4X4_50 markers in 10 views, laid out as a 5×7 board: pass --board 5x7" in r.stderr, r.stderr

    r = cli("calibrate", "--camera", str(video), "--dir", str(tmp_path), "--board", "5x7", "--json")
    assert r.returncode == 0, r.stderr
    out = json.loads(r.stdout.strip().splitlines()[-1])
    assert out["board"] == "5x7" and out["views"] >= 8, out
    assert abs(out["fx"] / truth.fx - 1) < 0.01 and abs(out["fy"] / truth.fy - 1) < 0.01, (out, truth)


def test_the_board_from_a_yaml_file_and_the_flags_over_it(tutorial_board, tmp_path):
    video, truth = tutorial_board
    (tmp_path / "board.yaml").write_text("squares: [7, 5]\nsquare_m: 0.03\nmarker_m: 0.022\ndictionary: 4X4_50\n")
    r = cli("calibrate", "--camera", str(video), "--dir", str(tmp_path), "--board-file", str(tmp_path / "board.yaml"))
    assert r.returncode == 1 and "pass --board 5x7" in r.stderr, r.stderr
    (tmp_path / "board.yaml").write_text("squares: [5, 7]\n")
    r = cli("calibrate", "--camera", str(video), "--dir", str(tmp_path), "--board-file", str(tmp_path / "board.yaml"),
            "--json")  # fmt: skip
    assert r.returncode == 0 and json.loads(r.stdout)["board"] == "5x7", r.stderr


def test_the_hint_names_another_dictionary_and_the_legacy_pattern():
    """Markers of another dictionary are named; a board with an even number of rows in OpenCV's legacy pattern is
    told from the current one by where its markers sit (frames rendered in memory, no video)."""
    from recorder import quat
    from recorder.wrist.board import BoardSpec
    from recorder.wrist.board_hint import what_the_views_show
    from recorder.wrist.calibration import calibrate
    from recorder.wrist.marker import PlateScene

    def views(board):
        scene = PlateScene(board.image(), board.size_m())
        face = quat.from_two_vectors(np.array([0.0, 0, 1]), np.array([-1.0, 0, 0]))  # the plate facing the camera
        try:
            return [scene.render([d, 0.0, 0.0], face)[0] for d in (0.4, 0.45, 0.5, 0.55, 0.6)]
        finally:
            scene.close()

    frames = views(BoardSpec(dictionary="5X5_100"))
    assert what_the_views_show(frames, BoardSpec()) == (
        "found 5X5_100 markers in 5 views, laid out as a 7×5 board: pass --dictionary 5X5_100"
    )
    frames = views(BoardSpec(squares=(8, 6), legacy=True))
    with pytest.raises(Exception, match=r"laid out as an 8×6 board in the legacy pattern: pass --legacy$"):
        calibrate(frames, BoardSpec(squares=(8, 6)))
    assert what_the_views_show(frames, BoardSpec(squares=(8, 6), legacy=True)) is None  # the right board: no hint


@pytest.mark.parametrize(
    "args, says",
    [
        (["--board", "5"], "argument --board: expected the board's squares across x down, e.g. 5x7, got '5'"),
        (["--board", "1x7"], "got '1x7'"),
        (["--square-mm", "-3"], "argument --square-mm: must be positive"),
        (["--marker-mm", "35"], "the board's markers (35 mm) must be smaller than its squares (30 mm)"),
        (["--dictionary", "9X9_1"], "unknown board dictionary '9X9_1'; valid: 4X4_50, 5X5_100, 6X6_250"),
        (["--board", "12x10"], "a 12×10 board has 60 markers: more than 4X4_50 holds (50)"),
        (["--board-file", "missing.yaml"], "no such config file: missing.yaml"),
    ],
)
def test_a_bad_board_is_one_line(args, says, tmp_path):
    r = cli("calibrate", "--camera", str(tmp_path / "never_opened.mkv"), *args)
    assert r.returncode in (1, 2) and says in r.stderr and r.stderr.count("\n") == 1, r.stderr
    assert "Traceback" not in r.stderr


def test_a_bad_board_file_names_the_file_and_key(tmp_path):
    for text, says in (("squares: [5, 7]\nsize: 3\n", "size: unknown key; valid: squares"),
                       ("squares: five\n", "squares:"), ("legacy: maybe\n", "legacy:")):  # fmt: skip
        (tmp_path / "b.yaml").write_text(text)
        r = cli("board", "--out", str(tmp_path / "b.png"), "--board-file", str(tmp_path / "b.yaml"))
        assert r.returncode == 1 and f"{tmp_path / 'b.yaml'}: " in r.stderr and says in r.stderr, r.stderr
        assert r.stderr.count("\n") == 1 and not (tmp_path / "b.png").exists()


def test_board_flags_without_camera_are_one_line():
    r = cli("calibrate", "--glove", "emulator", "--board", "5x7")
    assert r.returncode == 1 and "--board describes the board of --camera CAMERA" in r.stderr, r.stderr


def test_the_printable_png_is_the_board_at_its_dpi(tmp_path):
    from PIL import Image

    out = tmp_path / "board.png"
    r = cli("board", "--out", str(out), "--board", "5x7", "--dpi", "200", "--margin-mm", "10")
    assert r.returncode == 0, r.stderr
    image = Image.open(out)
    per_square, margin = round(30 / 25.4 * 200), round(10 / 25.4 * 200)  # 236 px a square, 79 px of margin
    assert image.size == (5 * per_square + 2 * margin, 7 * per_square + 2 * margin)
    assert image.info["dpi"] == pytest.approx((200, 200), abs=0.01)
    assert "150 x 210 mm" in r.stdout


def test_the_printable_pdf_page_is_the_board_plus_its_margins(tmp_path):
    out = tmp_path / "board.pdf"
    r = cli("board", "--out", str(out), "--board", "5x7", "--square-mm", "40", "--marker-mm", "30", "--legacy",
            "--margin-mm", "15")  # fmt: skip
    assert r.returncode == 0, r.stderr
    box = re.search(rb"/MediaBox \[ *0 +0 +([\d.]+) +([\d.]+) *\]", out.read_bytes())
    width_mm, height_mm = (float(v) / 72 * 25.4 for v in box.groups())
    assert width_mm == pytest.approx(5 * 40 + 2 * 15, abs=0.01) and height_mm == pytest.approx(
        7 * 40 + 2 * 15, abs=0.01
    )
    for bad, says in ((["--out", str(tmp_path / "b.jpg")], "is a .pdf or a .png"),
                      (["--out", str(tmp_path / "no" / "b.pdf")], "no such folder")):  # fmt: skip
        r = cli("board", *bad)
        assert r.returncode == 1 and says in r.stderr and r.stderr.count("\n") == 1, r.stderr
