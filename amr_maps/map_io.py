"""The ROS map_server file format (name.yaml + image) both ways, as nav2_map_server's map_io does it.

YAML keys: `image` (path, relative to the YAML), `resolution` (m/pixel), `origin` [x, y, yaw] of the
lower-left pixel, `occupied_thresh`, `free_thresh`, `negate` (0/1), `mode` (trinary | scale | raw,
optional, default trinary). Loading follows nav2's loadMapFromFile:

    shade = mean of the pixel's R, G, B in [0, 1] (in trinary mode, alpha is averaged in too)
    p = 1 - shade, or shade when negate
    trinary: p > occupied_thresh -> 100, p < free_thresh -> 0, else -1
    scale:   transparent -> -1, then the same ends, else rint(100 (p - free) / (occupied - free))
    raw:     v = round(255 shade); 0 <= v <= 100 -> v, else -1

Image row 0 is the top of the map, so it becomes grid row height - 1. Saving follows nav2's map saver:
trinary writes 0 (occupied), 254 (free), 205 (unknown); scale writes grey (100 - v) / 100 with
unknown transparent (PNG only); raw writes v with unknown 255. Pillow reads and writes the images.
Unlike nav2 (which keeps 3 significant digits), the YAML keeps full float precision.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import yaml
from PIL import Image, UnidentifiedImageError

from amr_maps.occupancy_grid import FREE, OCCUPIED, UNKNOWN, MapError, OccupancyGrid
from amr_util.geometry import is_finite_number

MODES = ("trinary", "scale", "raw")
REQUIRED_KEYS = ("image", "resolution", "origin", "occupied_thresh", "free_thresh", "negate")
DEFAULT_OCCUPIED_THRESH = 0.65
DEFAULT_FREE_THRESH = 0.196
IMAGE_FORMATS = {"pgm": "PPM", "png": "PNG", "bmp": "BMP"}
TRINARY_OCCUPIED, TRINARY_FREE, TRINARY_UNKNOWN = 0, 254, 205
RAW_UNKNOWN = 255


def map_yaml_keys(path: str | Path) -> dict:
    """The parsed map YAML, checked key by key (the metadata nav2's loadMapYaml reads)."""
    path = Path(path)
    try:
        data = yaml.safe_load(path.read_text(encoding="utf-8"))
    except OSError as error:
        raise MapError(f"{path}: cannot read map file ({error.strerror})") from error
    except yaml.YAMLError as error:
        raise MapError(f"{path}: not valid YAML ({error})") from error
    if not isinstance(data, dict):
        raise MapError(f"{path}: a map file must be a mapping of keys, got {type(data).__name__}")
    for key in REQUIRED_KEYS:
        if key not in data:
            raise MapError(f"{path}: {key}: missing (a map file needs {', '.join(REQUIRED_KEYS)})")

    image = data["image"]
    if not isinstance(image, str) or not image:
        raise MapError(f"{path}: image: must be a non-empty file name, got {image!r}")
    image_path = Path(image) if Path(image).is_absolute() else path.parent / image
    resolution = _number(data, "resolution", path)
    if resolution <= 0.0:
        raise MapError(f"{path}: resolution: must be positive, got {resolution}")
    origin = data["origin"]
    if not (isinstance(origin, list) and len(origin) == 3 and all(map(is_finite_number, origin))):
        raise MapError(f"{path}: origin: expected [x, y, yaw] (3 finite numbers), got {origin!r}")
    occupied = _number(data, "occupied_thresh", path)
    free = _number(data, "free_thresh", path)
    if not 0.0 <= occupied <= 1.0:
        raise MapError(f"{path}: occupied_thresh: must lie in [0, 1], got {occupied}")
    if not 0.0 <= free <= 1.0:
        raise MapError(f"{path}: free_thresh: must lie in [0, 1], got {free}")
    if not free < occupied:
        raise MapError(f"{path}: free_thresh: must be below occupied_thresh ({free} >= {occupied})")
    negate = data["negate"]
    if negate not in (0, 1) or isinstance(negate, float):
        raise MapError(f"{path}: negate: must be 0 or 1 (or a boolean), got {negate!r}")
    mode = data.get("mode", "trinary")
    if mode not in MODES:
        raise MapError(f"{path}: mode: must be one of {', '.join(MODES)}, got {mode!r}")
    return {
        "image": image_path,
        "resolution": resolution,
        "origin": tuple(float(v) for v in origin),
        "occupied_thresh": occupied,
        "free_thresh": free,
        "negate": bool(negate),
        "mode": mode,
    }


def load_map(path: str | Path, frame_id: str = "map") -> OccupancyGrid:
    """Read a map_server YAML and its image into an OccupancyGrid, refusing bad files by name."""
    path = Path(path)
    keys = map_yaml_keys(path)
    shade, alpha = _read_image(keys["image"], path)
    values = occupancy_from_pixels(
        shade, alpha, keys["mode"], keys["negate"], keys["occupied_thresh"], keys["free_thresh"]
    )
    try:
        return OccupancyGrid(values[::-1], keys["resolution"], keys["origin"], frame_id)
    except MapError as error:
        raise MapError(f"{path}: origin: {error}") from error


def occupancy_from_pixels(
    shade: np.ndarray, alpha: np.ndarray | None, mode: str, negate: bool, occupied_thresh: float, free_thresh: float
) -> np.ndarray:
    """Cell values (image rows, top first) from channel-mean brightness and alpha in [0, 1]."""
    if mode == "raw":
        raw = np.rint(shade * 255.0)
        return np.where(raw <= OCCUPIED, raw, UNKNOWN).astype(np.int8)
    if mode == "trinary" and alpha is not None:  # nav2 averages alpha in with R, G, B
        shade = (3.0 * shade + alpha) / 4.0
    p = shade if negate else 1.0 - shade
    values = np.full(shade.shape, UNKNOWN, dtype=np.int8)
    if mode == "scale":
        between = np.rint((p - free_thresh) / (occupied_thresh - free_thresh) * 100.0)
        values[:] = np.clip(between, 0, 100)
    values[p > occupied_thresh] = OCCUPIED
    values[p < free_thresh] = FREE
    if mode == "scale" and alpha is not None:
        values[alpha < 1.0] = UNKNOWN
    return values


def _read_image(image_path: Path, yaml_path: Path) -> tuple[np.ndarray, np.ndarray | None]:
    """(channel-mean brightness, alpha or None), both in [0, 1], image rows top first."""
    where = f"{yaml_path}: image: {image_path}"
    if not image_path.is_file():
        raise MapError(f"{where}: image file not found")
    try:
        with Image.open(image_path) as image:
            image.load()
            return _brightness(image)
    except (UnidentifiedImageError, OSError, ValueError, SyntaxError) as error:
        raise MapError(f"{where}: not a readable image ({error})") from error


def _brightness(image: Image.Image) -> tuple[np.ndarray, np.ndarray | None]:
    if image.mode in ("I;16", "I;16B", "I;16L", "I"):  # 16-bit greyscale PGM/PNG
        pixels = np.asarray(image, dtype=np.float64)
        top = 65535.0 if image.mode.startswith("I;16") or pixels.max(initial=0) > 255 else 255.0
        return np.clip(pixels / top, 0.0, 1.0), None
    has_alpha = image.mode in ("LA", "RGBA", "PA") or (image.mode == "P" and "transparency" in image.info)
    pixels = np.asarray(image.convert("RGBA" if has_alpha else "RGB"), dtype=np.float64) / 255.0
    return pixels[..., :3].mean(axis=2), (pixels[..., 3] if has_alpha else None)


def save_map(
    grid: OccupancyGrid,
    path: str | Path,
    mode: str = "trinary",
    image_format: str = "pgm",
    occupied_thresh: float = DEFAULT_OCCUPIED_THRESH,
    free_thresh: float = DEFAULT_FREE_THRESH,
) -> Path:
    """Write `path` (name.yaml, or a stem) and its image beside it; returns the YAML path."""
    if mode not in MODES:
        raise MapError(f"save_map: mode must be one of {', '.join(MODES)}, got {mode!r}")
    if image_format not in IMAGE_FORMATS:
        raise MapError(f"save_map: image_format must be one of {', '.join(IMAGE_FORMATS)}, got {image_format!r}")
    if mode == "scale" and image_format != "png":
        raise MapError("save_map: scale mode marks unknown cells transparent, which needs image_format png")
    if not 0.0 <= free_thresh < occupied_thresh <= 1.0:
        raise MapError(f"save_map: need 0 <= free_thresh < occupied_thresh <= 1, got {free_thresh}, {occupied_thresh}")
    path = Path(path)
    yaml_path = path if path.suffix in (".yaml", ".yml") else path.with_name(path.name + ".yaml")
    image_path = yaml_path.with_suffix("." + image_format)
    yaml_path.parent.mkdir(parents=True, exist_ok=True)

    pixels = pixels_from_occupancy(grid.data[::-1], mode, occupied_thresh, free_thresh)
    Image.fromarray(pixels).save(image_path, format=IMAGE_FORMATS[image_format])
    metadata = {
        "image": image_path.name,
        "mode": mode,
        "resolution": grid.resolution,
        "origin": [float(v) for v in grid.origin],
        "negate": 0,
        "occupied_thresh": float(occupied_thresh),
        "free_thresh": float(free_thresh),
    }
    yaml_path.write_text(yaml.safe_dump(metadata, sort_keys=False, default_flow_style=None), encoding="utf-8")
    return yaml_path


def pixels_from_occupancy(values: np.ndarray, mode: str, occupied_thresh: float, free_thresh: float) -> np.ndarray:
    """uint8 image (greyscale, or grey + alpha in scale mode) from cell values, rows as given."""
    values = np.asarray(values, dtype=np.int16)
    unknown = (values < 0) | (values > OCCUPIED)
    if mode == "trinary":
        pixels = np.full(values.shape, TRINARY_UNKNOWN, dtype=np.uint8)
        pixels[values <= round(free_thresh * 100)] = TRINARY_FREE
        pixels[values >= round(occupied_thresh * 100)] = TRINARY_OCCUPIED
        pixels[unknown] = TRINARY_UNKNOWN
        return pixels
    if mode == "raw":
        return np.where(unknown, RAW_UNKNOWN, values).astype(np.uint8)
    grey = np.rint(255.0 * (OCCUPIED - np.clip(values, 0, OCCUPIED)) / OCCUPIED).astype(np.uint8)
    grey[unknown] = 128
    return np.stack([grey, np.where(unknown, 0, 255).astype(np.uint8)], axis=-1)


def _number(data: dict, key: str, path: Path) -> float:
    value = data[key]
    if not is_finite_number(value):
        raise MapError(f"{path}: {key}: must be a finite number, got {value!r}")
    return float(value)
