#!/usr/bin/env python3
"""Reads a tiled build's world.tif back with GDAL (through rasterio) and checks it against
the build's own tiles: a tiled float32 GeoTIFF of the plan's size in the plan's tiles, with
overviews halving down to one tile (each cell the mean of the four below it), georeferenced
with square cells, and every cell the bits of its tile's file.

Usage: read-world.py BUILD_DIR   (BUILD_DIR: a `strahler build --out` directory)
"""

import json
import pathlib
import sys

import numpy as np
import rasterio


def fail(message):
    print(f"read-world: {message}", file=sys.stderr)
    sys.exit(1)


def main():
    build = pathlib.Path(sys.argv[1])
    plan = json.loads((build / "plan.json").read_text())
    size, tile = plan["size"], plan["tile"]
    per = -(-size // tile)
    world = np.empty((size, size), dtype="<f4")
    for row in range(per):
        for col in range(per):
            h, w = min(tile, size - row * tile), min(tile, size - col * tile)
            folder = "filled" if plan.get("fill") else "tiles"
            cells = np.fromfile(build / folder / f"r{row:03}-c{col:03}.f32", dtype="<f4")
            world[row * tile:row * tile + h, col * tile:col * tile + w] = cells.reshape(h, w)

    with rasterio.open(build / "world.tif") as tif:
        if (tif.driver, tif.count, tif.dtypes[0]) != ("GTiff", 1, "float32"):
            fail(f"a {tif.driver} of {tif.count} {tif.dtypes[0]} bands, not one float32 GeoTIFF band")
        if (tif.width, tif.height) != (size, size):
            fail(f"{tif.width} x {tif.height} cells, not the plan's {size}^2")
        if tif.block_shapes != [(tile, tile)]:
            fail(f"blocks {tif.block_shapes}, not tiles of {tile}")
        factors = tif.overviews(1)
        halvings = [2 ** (k + 1) for k in range(len(factors))]
        if not factors or factors != halvings or -(-size // factors[-1]) > tile:
            fail(f"overviews {factors}: not halvings down to one tile of {tile}")
        a, _, _, _, e, _ = tif.transform[:6]
        if not (a > 0 and abs(a + e) < 1e-9 * a):
            fail(f"cells of {a} x {e}: not square, north up")
        cells = tif.read(1)
        if not np.array_equal(cells.view(np.uint32), world.view(np.uint32)):
            bad = np.argwhere(cells.view(np.uint32) != world.view(np.uint32))
            fail(f"{len(bad)} cells differ from the tiles' bits, the first at {tuple(bad[0])}")
    # The first overview: the mean of each 2 x 2 block (f32 rounding allowed).
    with rasterio.open(build / "world.tif", overview_level=0) as overview:
        half = overview.read(1)
    n = size // 2
    means = world[: 2 * n, : 2 * n].astype(np.float64).reshape(n, 2, n, 2).mean(axis=(1, 3))
    worst = float(np.max(np.abs(half[:n, :n] - means)))
    if worst > 1e-3 * max(1.0, float(np.max(np.abs(means)))):
        fail(f"the first overview is off the 2 x 2 means by up to {worst}")
    print(
        f"   GDAL {rasterio.__gdal_version__} reads world.tif: {size}^2 float32 in tiles of {tile}, "
        f"overviews {factors}, cells of {a:.3f} m, every cell the tiles' bits"
    )


if __name__ == "__main__":
    main()
