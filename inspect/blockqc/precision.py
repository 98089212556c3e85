"""The resolution a table file's stored number type gives its ground coordinates.

A Parquet table may store a column as float32 (or float16): its values are read as stored, and
a longitude near 100° then holds to 7.6e-6° (0.85 m east-west), a UTM northing near 4.4e6 m to
0.5 m. Checkpoint errors of metres computed from such columns are off by up to that much, and
nothing would say so. Every table of the contract read from a file is checked here, by the
ground columns its schema marks (`Column.ground`): each such column stored coarser than float64
is said, with the resolution its type gives at the column's largest magnitude (the spacing of
that type there, in metres: degrees taken at 111 319.49 m, a degree along the equator), and the
stock rules whose figures it bounds. Beyond `COARSE_SHARE` of the plane norm it is said as
coarse: those figures may be off by a share of the norm that matters. The table is read still.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pyarrow as pa
import pyarrow.parquet as pq

from blockqc.errors import Problem
from blockqc.schema import TableSchema

#: ground metres per degree along the equator (WGS-84: 2π · 6 378 137 m / 360), the most a
#: degree of longitude or latitude spans
METRES_PER_DEGREE = 111_319.49
#: a column whose stored resolution exceeds this share of the plane norm is said as coarse
COARSE_SHARE = 0.1

SAID = (
    "{columns} (the resolution of each at its largest value) stored as {type}, not float64: "
    "the figures of {figures} are no finer than that"
)
SAID_COARSE = (
    "{columns} (the resolution of each at its largest value) stored as {type}, not float64: "
    "coarser than {share} of the plane norm ({limit} m), the figures of {figures} may be off "
    "by that much; write these columns as float64 (double)"
)


def stored_types(path: Path) -> dict[str, np.dtype]:
    """The floating columns of a Parquet file stored coarser than float64, by name (stripped);
    {} for another file or one whose schema cannot be read (reading it says why)."""
    if path.suffix.lower() != ".parquet":
        return {}
    try:
        found = pq.read_schema(path)
    except (pa.ArrowException, OSError):
        return {}
    return {
        f.name.strip(): np.dtype(f.type.to_pandas_dtype())
        for f in found
        if pa.types.is_floating(f.type) and f.type.bit_width < 64
    }


def resolution_m(values: np.ndarray, dtype: np.dtype, degrees: bool) -> float | None:
    """The spacing of `dtype` at the largest magnitude of `values`, in metres (None: no
    value)."""
    values = np.asarray(values, np.float64)
    if values.size == 0 or np.isnan(values).all():
        return None
    largest = max(-float(np.nanmin(values)), float(np.nanmax(values)))  # no |values| made
    step = float(np.spacing(dtype.type(largest)))
    return step * METRES_PER_DEGREE if degrees else step


def stored_resolution(path: Path, schema: TableSchema, table: pd.DataFrame) -> list[Problem]:
    """A warning naming the ground columns of a table file stored coarser than float64, each
    with the resolution its type gives it, and the rules whose figures they bound."""
    coarse = stored_types(path)
    columns = [c for c in schema.columns if c.ground and c.name in coarse and c.name in table]
    found = [
        (c, step)
        for c in columns
        if (step := resolution_m(table[c.name].to_numpy(), coarse[c.name], c.ground == "deg"))
        is not None
    ]
    if not found:
        return []
    shown = ", ".join(f"{c.name} {step:.3g} m" for c, step in found)
    figures = ", ".join(dict.fromkeys(r for c, _ in found for r in c.figures.split(", ")))
    types = ", ".join(dict.fromkeys(str(coarse[c.name]) for c, _ in found))
    from blockqc.metrics.checkpoints import AccuracyParams  # imports the reader: not above

    limit = COARSE_SHARE * AccuracyParams().plane_norm_m  # the stock plane norm (§CP)
    text = SAID_COARSE if max(step for _, step in found) > limit else SAID
    message = text.format(
        columns=shown, type=types, figures=figures, share=f"{COARSE_SHARE:g}", limit=f"{limit:g}"
    )
    return [Problem(str(path), message)]
