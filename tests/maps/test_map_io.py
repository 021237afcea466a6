"""map_server files both ways: nav2's pixel rules, the saver's bytes, and malformed files refused by name."""

import numpy as np
import pytest
import yaml
from PIL import Image

from amr_maps.map_io import load_map, save_map
from amr_maps.occupancy_grid import MapError, OccupancyGrid

RNG = np.random.default_rng(11)


def random_grid(rng, height, width, values=(-1, 0, 100), resolution=0.05):
    data = rng.choice(np.array(values, dtype=np.int8), size=(height, width))
    origin = (float(rng.uniform(-10, 10)), float(rng.uniform(-10, 10)), 0.0)
    return OccupancyGrid(data, resolution, origin)


@pytest.mark.parametrize("image_format", ["pgm", "png", "bmp"])
@pytest.mark.parametrize("shape", [(1, 1), (7, 13), (64, 3)])
def test_trinary_maps_come_back_cell_for_cell(tmp_path, image_format, shape):
    grid = random_grid(RNG, *shape, resolution=float(RNG.uniform(0.01, 0.2)))
    path = save_map(grid, tmp_path / "sub" / "lab", image_format=image_format)
    assert path == tmp_path / "sub" / "lab.yaml" and (tmp_path / "sub" / f"lab.{image_format}").is_file()
    loaded = load_map(path)
    assert np.array_equal(loaded.data, grid.data)
    assert loaded.resolution == grid.resolution and loaded.origin == grid.origin


def test_trinary_classes_in_between_values_by_the_thresholds(tmp_path):
    grid = OccupancyGrid(np.arange(-1, 101, dtype=np.int8).reshape(1, -1), 0.1)
    loaded = load_map(save_map(grid, tmp_path / "m", occupied_thresh=0.65, free_thresh=0.196))
    expected = np.where(np.arange(-1, 101) >= 65, 100, np.where(np.arange(-1, 101) <= 20, 0, -1))
    expected[0] = -1
    assert np.array_equal(loaded.data[0], expected)


def test_raw_maps_keep_every_value(tmp_path):
    grid = random_grid(RNG, 9, 17, values=tuple(range(-1, 101)))
    assert np.array_equal(load_map(save_map(grid, tmp_path / "raw", mode="raw")).data, grid.data)


def test_scale_maps_keep_free_occupied_unknown_and_order_in_between(tmp_path):
    values = np.arange(-1, 101, dtype=np.int8).reshape(1, -1)
    loaded = load_map(save_map(OccupancyGrid(values, 0.1), tmp_path / "s", mode="scale", image_format="png"))
    out = loaded.data[0].astype(int)
    assert out[0] == -1 and out[1] == 0 and out[-1] == 100
    assert np.all(np.diff(out[1:]) >= 0)
    with pytest.raises(MapError, match="png"):
        save_map(OccupancyGrid(values, 0.1), tmp_path / "s", mode="scale", image_format="pgm")


def test_the_saved_files_are_what_nav2_map_server_reads(tmp_path):
    data = np.array([[0, 100, -1], [100, 0, 0]], dtype=np.int8)  # row 0 is the bottom row
    path = save_map(OccupancyGrid(data, 0.025, (-1.5, 2.25, 0.0)), tmp_path / "lab")
    raw = (tmp_path / "lab.pgm").read_bytes()
    assert raw[:11] == b"P5\n3 2\n255\n"
    assert list(raw[11:]) == [0, 254, 254, 254, 0, 205]  # the top image row is grid row 1
    meta = yaml.safe_load(path.read_text())
    assert meta == {
        "image": "lab.pgm",
        "mode": "trinary",
        "resolution": 0.025,
        "origin": [-1.5, 2.25, 0.0],
        "negate": 0,
        "occupied_thresh": 0.65,
        "free_thresh": 0.196,
    }


def nav2_pixel(rgba, has_alpha, mode, negate, occupied, free):
    """One pixel by nav2_map_server's loadMapFromFile, written out as its C++ reads."""
    channels = [int(c) for c in rgba[:3]]
    if mode == "trinary" and has_alpha:
        channels.append(int(rgba[3]))
    shade = sum(channels) / len(channels) / 255.0
    occ = shade if negate else 1.0 - shade
    if mode == "trinary":
        return 100 if occupied < occ else 0 if occ < free else -1
    if mode == "scale":
        if has_alpha and rgba[3] != 255:
            return -1
        return 100 if occupied < occ else 0 if occ < free else int(np.rint((occ - free) / (occupied - free) * 100))
    value = round(shade * 255)
    return value if 0 <= value <= 100 else -1


@pytest.mark.parametrize("image_mode", ["L", "LA", "RGB", "RGBA", "P"])
@pytest.mark.parametrize("mode", ["trinary", "scale", "raw"])
@pytest.mark.parametrize("negate", [0, 1])
def test_images_load_by_nav2_pixel_rules(tmp_path, image_mode, mode, negate):
    rng = np.random.default_rng(hash((image_mode, mode, negate)) % 2**32)
    rgba = rng.integers(0, 256, size=(6, 8, 4), dtype=np.uint8)
    rgba[..., 3] = rng.choice([0, 128, 255, 255], size=(6, 8))
    if image_mode in ("L", "LA"):
        rgba[..., 1] = rgba[..., 2] = rgba[..., 0]
    image = Image.fromarray(rgba, "RGBA")
    image = image.convert("RGB").convert("P") if image_mode == "P" else image.convert(image_mode)
    image.save(tmp_path / "m.png")
    occupied, free = sorted(rng.uniform(0.05, 0.95, 2))[::-1]
    (tmp_path / "m.yaml").write_text(
        yaml.safe_dump(
            {
                "image": "m.png",
                "resolution": 0.1,
                "origin": [0, 0, 0],
                "negate": negate,
                "mode": mode,
                "occupied_thresh": float(occupied),
                "free_thresh": float(free),
            }
        )
    )
    pixels = np.asarray(image.convert("RGBA"))
    has_alpha = image_mode in ("LA", "RGBA")
    expected = np.array([[nav2_pixel(p, has_alpha, mode, negate, occupied, free) for p in row] for row in pixels])
    assert np.array_equal(load_map(tmp_path / "m.yaml").data, expected[::-1])


GOOD = {
    "image": "m.pgm",
    "resolution": 0.05,
    "origin": [0.0, 0.0, 0.0],
    "negate": 0,
    "occupied_thresh": 0.65,
    "free_thresh": 0.196,
}


@pytest.mark.parametrize(
    "change, key",
    [
        ({"image": None}, "image"),
        ({"resolution": None}, "resolution"),
        ({"origin": None}, "origin"),
        ({"negate": None}, "negate"),
        ({"occupied_thresh": None}, "occupied_thresh"),
        ({"free_thresh": None}, "free_thresh"),
        ({"image": "missing.pgm"}, "image"),
        ({"image": ""}, "image"),
        ({"occupied_thresh": 1.5}, "occupied_thresh"),
        ({"free_thresh": -0.1}, "free_thresh"),
        ({"free_thresh": 0.7}, "free_thresh"),
        ({"occupied_thresh": float("nan")}, "occupied_thresh"),
        ({"origin": [0.0, 0.0]}, "origin"),
        ({"origin": ["a", 0, 0]}, "origin"),
        ({"origin": [0, 0, 0.5]}, "origin"),
        ({"resolution": 0}, "resolution"),
        ({"resolution": "fine"}, "resolution"),
        ({"mode": "colour"}, "mode"),
        ({"negate": 2}, "negate"),
    ],
)
def test_malformed_map_files_are_refused_naming_file_and_key(tmp_path, change, key):
    save_map(OccupancyGrid(np.zeros((2, 2), np.int8), 0.05), tmp_path / "m")
    meta = {k: v for k, v in {**GOOD, **change}.items() if v is not None}
    (tmp_path / "m.yaml").write_text(yaml.safe_dump(meta))
    with pytest.raises(MapError, match=rf"m\.yaml: {key}:"):
        load_map(tmp_path / "m.yaml")


@pytest.mark.parametrize(
    "content", [b"", b"P5\n4 4\n255\n\x00\x00", b"not an image at all"], ids=["empty", "truncated", "garbage"]
)
def test_broken_images_are_refused_naming_the_image(tmp_path, content):
    (tmp_path / "m.pgm").write_bytes(content)
    (tmp_path / "m.yaml").write_text(yaml.safe_dump(GOOD))
    with pytest.raises(MapError, match=r"m\.yaml: image: .*m\.pgm"):
        load_map(tmp_path / "m.yaml")


@pytest.mark.parametrize("text", ["", "[1, 2]", "image: [unclosed"])
def test_yaml_that_is_not_a_map_is_refused(tmp_path, text):
    (tmp_path / "m.yaml").write_text(text)
    with pytest.raises(MapError, match=r"m\.yaml"):
        load_map(tmp_path / "m.yaml")
    with pytest.raises(MapError, match="cannot read"):
        load_map(tmp_path / "absent.yaml")


def test_a_16_bit_pgm_and_an_absolute_image_path_load(tmp_path):
    image = Image.fromarray(np.array([[0, 65535], [40000, 20000]], dtype=np.uint16))
    image.save(tmp_path / "deep.png")
    meta = {**GOOD, "image": str(tmp_path / "deep.png")}
    (tmp_path / "other").mkdir()
    (tmp_path / "other" / "m.yaml").write_text(yaml.safe_dump(meta))
    loaded = load_map(tmp_path / "other" / "m.yaml")
    # image rows: p = 1, 0 (top), then 0.39 (unknown), 0.69 (occupied); the top row is grid row 1
    assert loaded.data.tolist() == [[-1, 100], [100, 0]]
