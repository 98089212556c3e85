"""RFM (RPC) geometry: models, readers, DEMs, orthorectification and §RA accuracy.

Image coordinates are (row, col) with the pixel-centre convention, the centre of the first pixel
of the full image being (0, 0); GDAL's RPC transformer counts pixel corners (+0.5 px); DIMAP files
count the first pixel as 1. Heights are WGS-84 ellipsoidal.
"""

from importlib import import_module
from typing import Any

#: where each name lives; the submodules are imported on first use (a DEM needs rasterio, an
#: ortho OpenCV: neither is needed to read a delivery's RPCs)
_HOME = {
    "DEM": "dem",
    "constant_height": "dem",
    "load_dem": "dem",
    "ImageAffine": "model",
    "RefinedRFM": "model",
    "RPCModel": "model",
    "fit_affine": "model",
    "OrthoGrid": "ortho",
    "ortho_grid": "ortho",
    "orthorectify": "ortho",
    "read_rpc": "readers",
}


def __getattr__(name: str) -> Any:
    if name not in _HOME:
        raise AttributeError(f"module 'blockqc.rfm' has no attribute {name!r}")
    return getattr(import_module(f"blockqc.rfm.{_HOME[name]}"), name)


__all__ = [
    "DEM",
    "ImageAffine",
    "OrthoGrid",
    "RPCModel",
    "RefinedRFM",
    "constant_height",
    "fit_affine",
    "load_dem",
    "ortho_grid",
    "orthorectify",
    "read_rpc",
]
