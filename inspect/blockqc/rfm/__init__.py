"""RFM (RPC) geometry: models, readers, DEMs, orthorectification and §RA accuracy.

Image coordinates are (row, col) with the pixel-centre convention, the centre of the first pixel
of the full image being (0, 0); GDAL's RPC transformer counts pixel corners (+0.5 px); DIMAP files
count the first pixel as 1. Heights are WGS-84 ellipsoidal.
"""

from blockqc.rfm.dem import DEM, constant_height, load_dem
from blockqc.rfm.model import ImageAffine, RefinedRFM, RPCModel, fit_affine
from blockqc.rfm.ortho import OrthoGrid, ortho_grid, orthorectify
from blockqc.rfm.readers import read_rpc

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
