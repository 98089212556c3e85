"""Benchmark of the §RA-3 matcher against OpenCV SIFT and ORB on real images with a known warp.

Each real image (benchmarks/data, see README.txt there) serves as the reference; the image to
check is the reference resampled through a known smooth displacement field (a bias of a few
pixels plus a smooth local distortion, at most about 3 px), with a radiometric change, a slight
blur and noise. Every method's CPs are compared with the applied field at their image position.

The real crops are 500 px wide, i.e. only 2×2 cells of 400 px; a 2000×2000 mosaic of the four
crops (flipped copies, radiometrically equalized, with a textureless 800×800 square, 2×2
cells, standing for calm water) gives a 5×5 grid for the cell statistic.

Run:  python benchmarks/matching_benchmark.py [--repeats N]
"""

from __future__ import annotations

import argparse
import time
import warnings
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np
import pandas as pd
import rasterio
from rasterio.errors import NotGeoreferencedWarning

from blockqc.matching import homogenize, match_candidates

DATA = Path(__file__).resolve().parent / "data"
GRID = 400
RANSAC_PX = 1.5  # same threshold for every method
NOISE_SHARE = 0.02  # noise sigma as a share of the image's 1-99 % range (0.05 for one scene)
DENSE = {"corners_per_cell": 1000, "harris_min_distance": 2}  # many matches, for the raw count
TEXTURE_FACTOR = 4.0  # cell corner strength must exceed this multiple of the noise's


def read(name: str) -> np.ndarray:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", NotGeoreferencedWarning)
        with rasterio.open(DATA / name) as ds:
            return ds.read(1).astype(np.float32)


def field(rows: np.ndarray, cols: np.ndarray, shape: tuple[int, int]) -> tuple[np.ndarray, ...]:
    """Applied displacement (d_row, d_col): reference position = image position + displacement."""
    h, w = shape
    u, v = rows / h, cols / w
    s = 0.2
    bump1 = np.exp(-((u - 0.3) ** 2 + (v - 0.7) ** 2) / (2 * s**2))
    bump2 = np.exp(-((u - 0.7) ** 2 + (v - 0.3) ** 2) / (2 * (1.25 * s) ** 2))
    d_row = 1.6 + 0.8 * np.sin(2 * np.pi * 1.3 * v + 0.4) + 0.6 * bump1
    d_col = -2.2 + 0.7 * np.cos(2 * np.pi * 1.1 * u) - 0.6 * bump2 + 0.3 * u * v
    return d_row, d_col


@dataclass
class Scene:
    name: str
    reference: np.ndarray
    image: np.ndarray
    clean: np.ndarray  # the warped image before the radiometric change and noise
    valid: np.ndarray
    noise: float


def make_scene(name: str, reference: np.ndarray, seed: int, noise_share: float) -> Scene:
    h, w = reference.shape
    rows, cols = np.mgrid[0:h, 0:w].astype(np.float64)
    d_row, d_col = field(rows, cols, (h, w))
    map_r = (rows + d_row).astype(np.float32)
    map_c = (cols + d_col).astype(np.float32)
    clean = cv2.remap(reference, map_c, map_r, cv2.INTER_CUBIC, borderMode=cv2.BORDER_REFLECT)
    valid = (map_r >= 2) & (map_r <= h - 3) & (map_c >= 2) & (map_c <= w - 3)
    lo, hi = np.percentile(reference, [1, 99])
    unit = np.clip((clean - lo) / (hi - lo), 0, None)
    image = lo + 1.1 * (hi - lo) * unit**0.85 + 25.0  # gain, gamma and offset change
    image = cv2.GaussianBlur(image.astype(np.float32), (0, 0), 0.6)
    noise = noise_share * float(hi - lo)
    image = image + np.random.default_rng(seed).normal(0, noise, image.shape)
    return Scene(name, reference, image.astype(np.float32), clean, valid, noise)


def mosaic() -> np.ndarray:
    """2000×2000 mosaic of the four crops in four orientations, 2×2 cells flat (no texture)."""
    names = ["phr_ventoux_left.tif", "phr_ventoux_right.tif", "wv3_20.tif", "wv3_30.tif"]
    crops = []
    for n in names:
        a = read(n)
        a = cv2.copyMakeBorder(a, 0, 500 - a.shape[0], 0, 500 - a.shape[1], cv2.BORDER_REFLECT)
        crops.append((a - a.mean()) / a.std() * 150.0 + 600.0)
    flips = [lambda a: a, np.fliplr, np.flipud, lambda a: a[::-1, ::-1]]
    out = np.empty((2000, 2000), np.float32)
    for i in range(4):
        for j in range(4):
            out[500 * i : 500 * i + 500, 500 * j : 500 * j + 500] = flips[i](crops[(i + j) % 4])
    rng = np.random.default_rng(7)
    # "Water": flat over image cells (2..3, 1..2) and 30 px beyond, more than the displacement
    # plus the template half, so nothing in those four cells can be matched on real structure.
    out[770:1630, 370:1230] = 600.0 + rng.normal(0, 1.0, (860, 860))
    return out


def cells(rows: np.ndarray, cols: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    return np.floor((rows + 0.5) / GRID).astype(int), np.floor((cols + 0.5) / GRID).astype(int)


def textured_cells(scene: Scene) -> set[tuple[int, int]]:
    """Cells whose 95th percentile of corner strength (smaller structure-tensor eigenvalue on the
    noise-free warped image) exceeds TEXTURE_FACTOR times that of the benchmark's noise alone."""
    strength = cv2.cornerMinEigenVal(scene.clean.astype(np.float32), 5, 3)
    noise = np.random.default_rng(0).normal(0, scene.noise, (512, 512)).astype(np.float32)
    floor = np.percentile(cv2.cornerMinEigenVal(noise, 5, 3), 95)
    h, w = strength.shape
    out = set()
    for cr in range(-(-h // GRID)):
        for cc in range(-(-w // GRID)):
            block = strength[cr * GRID : (cr + 1) * GRID, cc * GRID : (cc + 1) * GRID]
            ok = scene.valid[cr * GRID : (cr + 1) * GRID, cc * GRID : (cc + 1) * GRID]
            if ok.mean() > 0.5 and np.percentile(block[ok], 95) >= TEXTURE_FACTOR * floor:
                out.add((cr, cc))
    return out


def to_uint8(a: np.ndarray) -> np.ndarray:
    lo, hi = np.percentile(a, [0.5, 99.5])
    return np.clip((a - lo) / (hi - lo) * 255.0, 0, 255).astype(np.uint8)


def opencv_matches(scene: Scene, method: str) -> pd.DataFrame:
    """Keypoints + descriptors on both images, descriptor matching, RANSAC (affine)."""
    img8, ref8 = to_uint8(scene.image), to_uint8(scene.reference)
    mask = scene.valid.astype(np.uint8) * 255
    cv2.setRNGSeed(0)  # FLANN's randomized k-d trees: same trees on every run
    if method == "SIFT":
        det = cv2.SIFT_create()
    else:
        det = cv2.ORB_create(nfeatures=10000)
    kp1, d1 = det.detectAndCompute(img8, mask)
    kp2, d2 = det.detectAndCompute(ref8, None)
    if d1 is None or d2 is None or len(kp1) < 3 or len(kp2) < 3:
        return pd.DataFrame(columns=["row", "col", "ref_row", "ref_col", "score"])
    if method == "SIFT":  # approximate nearest neighbours (FLANN k-d trees), Lowe's ratio test
        flann = cv2.FlannBasedMatcher({"algorithm": 1, "trees": 5}, {"checks": 64})
        knn = flann.knnMatch(d1, d2, k=2)
        good = [m[0] for m in knn if len(m) == 2 and m[0].distance < 0.8 * m[1].distance]
    else:  # ORB: mutual nearest neighbours
        good = list(cv2.BFMatcher(cv2.NORM_HAMMING, crossCheck=True).match(d1, d2))
    if len(good) < 3:
        return pd.DataFrame(columns=["row", "col", "ref_row", "ref_col", "score"])
    p1 = np.array([kp1[m.queryIdx].pt for m in good], np.float64)  # (x, y) = (col, row)
    p2 = np.array([kp2[m.trainIdx].pt for m in good], np.float64)
    _, inl = cv2.estimateAffine2D(p1, p2, method=cv2.RANSAC, ransacReprojThreshold=RANSAC_PX)
    keep = inl.ravel().astype(bool) if inl is not None else np.zeros(len(good), bool)
    return pd.DataFrame(
        {
            "row": p1[keep, 1],
            "col": p1[keep, 0],
            "ref_row": p2[keep, 1],
            "ref_col": p2[keep, 0],
            "score": np.array([m.distance for m in good])[keep],
        }
    )


def one_per_cell(m: pd.DataFrame) -> pd.DataFrame:
    """Same homogenization for the baselines: per cell the match of smallest descriptor distance."""
    if m.empty:
        return m
    cr, cc = cells(m["row"].to_numpy(), m["col"].to_numpy())
    m = m.assign(cell_row=cr, cell_col=cc).sort_values(["score", "row", "col"])
    return m.drop_duplicates(["cell_row", "cell_col"])


def errors(m: pd.DataFrame, shape: tuple[int, int]) -> np.ndarray:
    rows, cols = m["row"].to_numpy(float), m["col"].to_numpy(float)
    d_row, d_col = field(rows, cols, shape)
    return np.hypot(
        m["ref_row"].to_numpy(float) - rows - d_row, m["ref_col"].to_numpy(float) - cols - d_col
    )


def timed(fn, repeats: int):
    times, result = [], None
    for _ in range(repeats):
        t0 = time.perf_counter()
        result = fn()
        times.append(time.perf_counter() - t0)
    return result, float(np.median(times))


def _ours(scene: Scene, settings: dict) -> tuple[pd.DataFrame, pd.DataFrame]:
    """match_images is homogenize(match_candidates(...)); both results are kept here."""
    raw = match_candidates(scene.image, scene.reference, image_valid=scene.valid, **settings)
    return raw, homogenize(raw, GRID)


def _baseline(scene: Scene, method: str) -> tuple[pd.DataFrame, pd.DataFrame]:
    raw = opencv_matches(scene, method)
    return raw, one_per_cell(raw)


def evaluate(scene: Scene, repeats: int) -> list[dict]:
    textured = textured_cells(scene)
    shape = scene.image.shape
    methods = {}
    for name, kw in (("ours", {}), ("ours B=1000", {"chunk": 1000}), ("ours dense", DENSE)):
        if name == "ours B=1000" and max(shape) <= 1000:
            continue
        methods[name] = lambda k=kw: _ours(scene, k)
    for name in ("SIFT", "ORB"):
        methods[name] = lambda m=name: _baseline(scene, m)
    rows = []
    for method, fn in methods.items():
        (all_matches, cps), seconds = timed(fn, repeats)
        err, err_all = errors(cps, shape), errors(all_matches, shape)
        got = set(zip(*cells(cps["row"].to_numpy(float), cps["col"].to_numpy(float)), strict=True))
        rows.append(
            {
                "scene": scene.name,
                "method": method,
                "matches": len(all_matches),
                "rms_all_px": np.sqrt(np.mean(err_all**2)) if len(err_all) else np.nan,
                "CPs": len(cps),
                "rms_cp_px": np.sqrt(np.mean(err**2)) if len(err) else np.nan,
                "max_cp_px": err.max() if len(err) else np.nan,
                "cells_textured": len(textured),
                "cells_covered_%": 100.0 * len(got & textured) / max(len(textured), 1),
                "CPs_untextured": len(got - textured),
                "time_s": seconds,
            }
        )
    return rows


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=3, help="timing repeats (median)")
    args = parser.parse_args()
    cv2.setNumThreads(1)  # same footing for every method
    big = mosaic()
    sources = [
        ("ventoux_left 500", read("phr_ventoux_left.tif"), NOISE_SHARE),
        ("ventoux_right 495x498", read("phr_ventoux_right.tif"), NOISE_SHARE),
        ("wv3_20 500", read("wv3_20.tif"), NOISE_SHARE),
        ("wv3_30 500", read("wv3_30.tif"), NOISE_SHARE),
        ("mosaic 2000", big, NOISE_SHARE),
        ("mosaic 2000 noise 5%", big, 0.05),
    ]
    results = []
    for k, (name, ref, noise) in enumerate(sources):
        results += evaluate(make_scene(name, ref, seed=100 + k, noise_share=noise), args.repeats)
    table = pd.DataFrame(results)
    pd.set_option("display.width", 200)
    print(table.to_string(index=False, float_format=lambda x: f"{x:.3f}"))
    print()
    for scene, part in table.groupby("scene", sort=False):
        by = part.set_index("method")
        ours, dense, sift = by.loc["ours"], by.loc["ours dense"], by.loc["SIFT"]
        print(
            f"{scene}: CPs ours {ours.CPs} / SIFT {sift.CPs} at {ours.time_s / sift.time_s:.2f} "
            f"of SIFT's time; all matches ours dense {dense.matches} / SIFT {sift.matches} at "
            f"{dense.time_s / sift.time_s:.2f} of SIFT's time"
        )


if __name__ == "__main__":
    main()
