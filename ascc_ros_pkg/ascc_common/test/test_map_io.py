"""ascc_common.map_io: the map_server reader (every mode, negate, thresholds, 8/16-bit and
colour images, rotated origins, one error per bad field) and the writer."""
import math

import cv2
import numpy as np
import pytest

from ascc_common.grid import FREE, OCCUPIED, UNKNOWN, GridInfo
from ascc_common.map_io import MapError, load_map, save_map

HEAD = {"resolution": 0.1, "origin": "[-1.0, 2.0, 0.0]", "negate": 0,
        "occupied_thresh": 0.65, "free_thresh": 0.196}


def write_map(tmp_path, pixels, name="m", ext=".pgm", **fields):
    """A map_server map from an image array (row 0 = top); returns the YAML path."""
    cv2.imwrite(str(tmp_path / (name + ext)), np.asarray(pixels))
    doc = dict(HEAD, image=name + ext)
    doc.update(fields)
    lines = ["%s: %s" % (k, v) for k, v in doc.items() if v is not None]
    path = tmp_path / (name + ".yaml")
    path.write_text("\n".join(lines) + "\n")
    return str(path)


def test_trinary_and_flip(tmp_path):
    img = np.full((4, 6), 254, dtype=np.uint8)  # free
    img[0, :] = 0          # top image row: occupied -> last map row
    img[3, 0] = 205        # unknown grey (p = 0.196 is not below free_thresh)
    grid, info = load_map(write_map(tmp_path, img))
    assert grid.shape == (4, 6) and info.resolution == 0.1
    assert (info.origin_x, info.origin_y, info.origin_yaw) == (-1.0, 2.0, 0.0)
    assert info.shape == grid.shape and grid.dtype == np.int8
    assert (grid[3] == OCCUPIED).all()
    assert grid[0, 0] == UNKNOWN and grid[0, 1] == FREE


def test_negate_thresholds_and_scale(tmp_path):
    img = np.array([[0, 128, 255]], np.uint8)
    g, _ = load_map(write_map(tmp_path, img, negate=1))
    assert g.tolist() == [[FREE, UNKNOWN, OCCUPIED]]
    g, _ = load_map(write_map(tmp_path, img, mode="scale"))
    assert g.tolist() == [[OCCUPIED, UNKNOWN, FREE]]   # in-between: unknown, not 1..99
    g, _ = load_map(write_map(tmp_path, img, occupied_thresh=0.4, free_thresh=0.3))
    assert g.tolist() == [[OCCUPIED, OCCUPIED, FREE]]
    g, _ = load_map(write_map(tmp_path, np.array([[100]], np.uint8), negate=1))
    assert g.tolist() == [[UNKNOWN]]                   # p = 0.39


def test_raw_mode_pixel_is_the_cell_value(tmp_path):
    img = np.array([[0, 10, 50, 70, 100, 101, 255]], np.uint8)
    g, _ = load_map(write_map(tmp_path, img, mode="raw"))
    # then the thresholding rule: <= 19 free, >= 65 occupied, > 100 (and 255 = -1) unknown
    assert g.tolist() == [[FREE, FREE, UNKNOWN, OCCUPIED, OCCUPIED, UNKNOWN, UNKNOWN]]
    g, _ = load_map(write_map(tmp_path, 255 - img, mode="raw", negate=1))
    assert g.tolist() == [[FREE, FREE, UNKNOWN, OCCUPIED, OCCUPIED, UNKNOWN, UNKNOWN]]


def test_16_bit_and_colour_images(tmp_path):
    g16 = np.array([[0, 65535, 205 * 257]], np.uint16)
    g, _ = load_map(write_map(tmp_path, g16, name="w", ext=".png"))
    assert g.tolist() == [[OCCUPIED, FREE, UNKNOWN]]
    bgr = np.zeros((1, 3, 3), np.uint8)
    bgr[0, 1] = (254, 254, 254)
    bgr[0, 2] = (255, 255, 105)       # mean 205: unknown
    g, _ = load_map(write_map(tmp_path, bgr, name="c", ext=".png"))
    assert g.tolist() == [[OCCUPIED, FREE, UNKNOWN]]
    bgra = np.zeros((1, 2, 4), np.uint8)
    bgra[0, 1] = (254, 254, 254, 0)   # alpha is ignored
    g, _ = load_map(write_map(tmp_path, bgra, name="a", ext=".png"))
    assert g.tolist() == [[OCCUPIED, FREE]]


def test_rotated_origin_is_read(tmp_path):
    _, info = load_map(write_map(tmp_path, np.zeros((2, 3), np.uint8),
                                 origin="[0.5, -1, 0.3]"))
    assert (info.origin_x, info.origin_y) == (0.5, -1.0)
    assert info.origin_yaw == pytest.approx(0.3) and not info.axis_aligned
    with pytest.raises(ValueError, match="rotated"):
        info.check_axis_aligned()


@pytest.mark.parametrize("fields, field, words", [
    ({"resolution": 0}, "resolution", "> 0"),
    ({"resolution": "fine"}, "resolution", "> 0"),
    ({"resolution": None}, "resolution", "missing"),
    ({"origin": None}, "origin", "missing"),
    ({"origin": "[0, 0]"}, "origin", "[x, y, yaw]"),
    ({"origin": "[0, 0, .nan]"}, "origin", "[x, y, yaw]"),
    ({"image": "missing.pgm"}, "image", "cannot read image"),
    ({"negate": 2}, "negate", "0 or 1"),
    ({"negate": "true"}, "negate", "0 or 1"),
    ({"occupied_thresh": 1.5}, "occupied_thresh", "0..1"),
    ({"free_thresh": 0.9}, "free_thresh", "below occupied_thresh"),
    ({"mode": "fancy"}, "mode", "trinary, scale, raw"),
    ({"colour": "red"}, "colour", "unknown field"),
])
def test_bad_field_names_file_and_field(tmp_path, fields, field, words):
    path = write_map(tmp_path, np.zeros((2, 2), np.uint8), **fields)
    with pytest.raises(MapError) as err:
        load_map(path)
    assert err.value.field == field and err.value.path == path
    assert str(err.value).startswith("%s: %s: " % (path, field)) and words in str(err.value)
    assert isinstance(err.value, ValueError)


def test_caller_may_restrict_the_modes(tmp_path):
    path = write_map(tmp_path, np.zeros((2, 2), np.uint8), mode="raw")
    with pytest.raises(MapError) as err:
        load_map(path, modes=("trinary", "scale"))
    assert err.value.field == "mode" and "trinary, scale," in err.value.message


def test_bad_map_files(tmp_path):
    with pytest.raises(OSError):
        load_map(str(tmp_path / "missing.yaml"))
    (tmp_path / "x.yaml").write_text("image: nothere.pgm\nresolution: 0.05\n"
                                     "origin: [0, 0, 0]\n")
    with pytest.raises(ValueError):
        load_map(str(tmp_path / "x.yaml"))
    (tmp_path / "y.yaml").write_text("just text\n")
    with pytest.raises(ValueError):
        load_map(str(tmp_path / "y.yaml"))
    (tmp_path / "z.yaml").write_text("image: [unclosed\n")
    with pytest.raises(MapError, match=r"\(yaml\): syntax error at line"):
        load_map(str(tmp_path / "z.yaml"))


def test_map_server_files_round_trip(tmp_path):
    g = np.full((12, 20), UNKNOWN, np.int8)
    g[2:10, 2:15] = FREE
    g[2, 2:15] = OCCUPIED
    info = GridInfo(0.05, 20, 12, -1.0, 3.0, 0.0)
    path = str(tmp_path / "m.yaml")
    assert save_map(path, g, info) == str(tmp_path / "m.pgm")
    g2, info2 = load_map(path)
    assert np.array_equal(g, g2) and info2 == info
    # Image row 0 is the top of the map (max y), grid row 0 the origin.
    img = cv2.imread(str(tmp_path / "m.pgm"), cv2.IMREAD_GRAYSCALE)
    assert img[-1 - 2, 5] == 0 and img[0, 0] == 205
    # a rotated origin and odd values survive (odd values are written as unknown)
    g[0, 0] = 50
    turned = GridInfo(0.1, 20, 12, 0.3, -0.7, math.pi / 3)
    save_map(str(tmp_path / "t.yaml"), g, turned, comment="made by a test")
    assert (tmp_path / "t.yaml").read_text().startswith("# made by a test\nimage: t.pgm\n")
    g3, info3 = load_map(str(tmp_path / "t.yaml"))
    assert info3 == turned and g3[0, 0] == UNKNOWN and np.array_equal(g3[1:], g2[1:])
    with pytest.raises(ValueError):
        save_map(str(tmp_path / "bad.yaml"), g, GridInfo(0.1, 3, 3))
