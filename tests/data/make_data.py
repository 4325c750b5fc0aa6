#!/usr/bin/env python3
"""Regenerates the test DEMs of tests/data/ (see README.md beside this file).

Run by hand only, from anywhere:

    pip install tifffile imagecodecs numpy
    python3 tests/data/make_data.py --src DIR [--gdal]

DIR (required) is the folder of the source DEMs, the files listed with their provenance in
README.md (they ship in public packages: PyPI shareloc, Debian r-cran-stars, npm
vega-datasets). The tests never run this script:
they read the files it wrote, which are committed.

What it does:
- copies olinda.tif/.png/.json and volcano_maungawhau.tif byte for byte;
- crops the SRTM tile srtm_n44e005.tif (1201 x 1201 float32, NaN voids, EPSG:4326) twice:
  `srtm_n44e005_voids` (112 x 120 cells around a cluster of voids in the Devoluy massif), written
  as float32 with NaN voids and again as int16, LZW, GDAL_NODATA = -32768, and
  `srtm_n44e005_crop` (80 x 120 cells, no voids, the southern Vercors);
- copies the georeferencing tags of the tile (ModelPixelScale 33550, ModelTiepoint 33922,
  GeoKeyDirectory 34735) with the tiepoint moved to the crop's upper-left corner;
- with --gdal, also rewrites gdal/ with GDAL's command-line tools (gdal-bin 3.6.2 made the
  committed files; see gdal/README.md);
- reads every file back and prints its size, z range and void count.
"""

import argparse
import shutil
import subprocess
from pathlib import Path

import numpy as np
import tifffile

HERE = Path(__file__).resolve().parent

TILE = "srtm_n44e005.tif"
# name: (first row, first column, rows, columns) in the tile.
CROPS = {
    "srtm_n44e005_voids": (258, 958, 112, 120),
    "srtm_n44e005_crop": (40, 480, 80, 120),
    # The largest relief among void-free 384 x 384 windows: Baronnies and the Ventoux's
    # north face, the real landscape the README's pictures and the realism tests compare with.
    "srtm_n44e005_384": (536, 424, 384, 384),
}
COPIES = ["olinda.tif", "olinda.png", "olinda.json", "volcano_maungawhau.tif"]
NODATA_INT16 = -32768


def georef_tags(page, row, col):
    """tifffile extratags with the tile's georeferencing moved to (row, col)."""
    scale = tuple(page.tags[33550].value)
    tie = list(page.tags[33922].value)
    keys = tuple(page.tags[34735].value)
    assert tie[0] == 0 and tie[1] == 0, "tiepoint at pixel (0, 0)"
    tie[3] += col * scale[0]
    tie[4] -= row * scale[1]
    return [
        (33550, "d", len(scale), scale, True),
        (33922, "d", len(tie), tuple(tie), True),
        (34735, "H", len(keys), keys, True),
    ]


def write(path, data, extratags, **kwargs):
    tifffile.imwrite(
        path,
        data,
        photometric="minisblack",
        rowsperstrip=16,
        metadata=None,
        software=False,
        extratags=extratags,
        **kwargs,
    )


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--src", type=Path, required=True, help="source DEM folder")
    parser.add_argument("--gdal", action="store_true", help="also rewrite gdal/ (needs gdal-bin)")
    args = parser.parse_args()
    src = args.src

    for name in COPIES:
        shutil.copyfile(src / name, HERE / name)

    with tifffile.TiffFile(src / TILE) as tif:
        page = tif.pages[0]
        tile = page.asarray()
        for name, (row, col, rows, cols) in CROPS.items():
            crop = tile[row : row + rows, col : col + cols].astype(np.float32)
            tags = georef_tags(page, row, col)
            voids = np.isnan(crop)
            if not name.endswith("_voids"):
                assert not voids.any(), f"{name} must be gap-free"
            # The larger crop is Deflate-compressed (about half the bytes).
            extra = {"compression": "zlib"} if name.endswith("_384") else {}
            write(HERE / f"{name}.tif", crop, tags + [(42113, "s", 0, "nan", True)], **extra)
            if name.endswith("_voids"):
                assert voids.any(), f"{name} must hold voids"
                finite = crop[~voids]
                assert np.all(finite == np.round(finite)), "SRTM heights are whole metres"
                ints = np.where(voids, NODATA_INT16, crop).astype(np.int16)
                write(
                    HERE / f"{name}_int16_lzw.tif",
                    ints,
                    tags + [(42113, "s", 0, str(NODATA_INT16), True)],
                    compression="lzw",
                )

    if args.gdal:
        write_gdal()
    verify()


GDAL_COMMANDS = [
    "gdal_translate -q -of AAIGrid srtm_n44e005_crop.tif gdal/srtm_n44e005_crop_gdal.asc",
    # NaN cells come out as `nan`.
    "gdal_translate -q -of AAIGrid -a_nodata -9999 srtm_n44e005_voids.tif"
    " gdal/srtm_n44e005_voids_gdal.asc",
    # The crop resampled to a whole SRTM3 tile, placed at N49E006 (the name gives the corner).
    "gdal_translate -q -of SRTMHGT -outsize 1201 1201 -r bilinear -ot Int16 -a_nodata none"
    " -a_srs EPSG:4326 -a_ullr 5.99958333 50.00041667 7.00041667 48.99958333"
    " srtm_n44e005_crop.tif gdal/N49E006.hgt",
    "rm -f gdal/*.prj gdal/*.aux.xml",
    # Writes gdal/N49E006.hgt.aux.xml with the statistics the test compares with.
    "gdalinfo -stats gdal/N49E006.hgt",
]


def write_gdal():
    for command in GDAL_COMMANDS:
        subprocess.run(command, shell=True, cwd=HERE, check=True, stdout=subprocess.DEVNULL)


def verify():
    for path in sorted(HERE.glob("*.tif")):
        with tifffile.TiffFile(path) as tif:
            page = tif.pages[0]
            data = page.asarray().astype(np.float64)
            nodata = page.tags.get(42113)
            nodata = nodata.value if nodata else None
            if nodata not in (None, "nan"):
                data[data == float(nodata)] = np.nan
            voids = int(np.isnan(data).sum())
            print(
                f"{path.name}: {page.shape[0]} rows x {page.shape[1]} cols, {page.dtype}, "
                f"{page.compression.name}, GDAL_NODATA={nodata!r}, "
                f"z {np.nanmin(data):g} .. {np.nanmax(data):g}, {voids} voids, "
                f"{path.stat().st_size} bytes"
            )


if __name__ == "__main__":
    main()
