"""Numbers, thresholds, groups and statuses for people: the one formatter of every page."""

from __future__ import annotations

import math
import re
from collections.abc import Iterable
from functools import cache
from typing import Any

import numpy as np

from blockqc.report.messages import MESSAGES, translator
from blockqc.results import RuleResult
from blockqc.rules.model import ON_BOUND

MISSING = "–"


def number(v: Any, digits: int | None = None) -> str:
    """A value for a table cell: integers whole, floats to `digits` decimals (3 below 1, else 2
    by default), tiny values in exponent form, missing or non-finite as an en dash."""
    if v is None:
        return MISSING
    if isinstance(v, np.generic):
        v = v.item()
    if isinstance(v, bool) or not isinstance(v, int | float):
        return str(v)
    if isinstance(v, int):
        return str(v)
    if not math.isfinite(v):
        return MISSING
    if v.is_integer() and abs(v) < 1e9 and digits is None:
        return str(int(v))
    d = digits if digits is not None else (3 if abs(v) < 1 else 2)
    if v != 0 and abs(v) < 10 ** (-d):
        return f"{v:.2e}"
    return f"{v:.{d}f}"


def number_beside(v: Any, limit: float, digits: int = 3) -> str:
    """`number(v, digits)`, or with as many more decimals as it takes (up to 12) for the figure
    shown to fall on the same side of `limit` as `v`: an RMSE of 0.99962 px that passes
    "< 1 px" reads 0.9996, not 1.000."""
    if not isinstance(v, float) or not math.isfinite(v) or not math.isfinite(limit):
        return number(v, digits)
    for d in range(digits, 13):
        shown = number(v, d)
        if (float(shown) < limit) == (v < limit):
            return shown
    return shown


def bound(v: Any, digits: int = 2) -> str:
    """A threshold as the specification writes it: 0.5, 2.6, 28.28 (two decimals at most, or
    the `digits` a value beside it needs to compare with it as it does: `_apart`)."""
    if isinstance(v, float) and math.isfinite(v):
        text = f"{v:.{digits}f}" if digits <= MAX_DECIMALS else f"{v:.12g}"
        return text.rstrip("0").rstrip(".") if "." in text and "e" not in text else text
    return number(v)


#: decimals a value and its bounds are shown with at most; beyond, 12 significant digits
MAX_DECIMALS = 6


#: fixed English phrases of results.json (the contract's text) and their catalogue keys, the
#: longest first: translated when a page is rendered, the results left as they are
PHRASES = (
    "ph_plan_no_cps",
    "ph_no_block_yaml",
    "ph_no_geometry",
    "ph_no_cps_not_sampled",
    "ph_not_sampled_plan",
    "awaiting_on",  # before its shorter "awaiting the inspector's verdict"
    "ph_awaiting",
    "ph_below_grades",
    "ph_nothing_measured",
    "ph_no_dz_column",
    "ph_dz_empty",
    "ph_plane_only",
    "ph_no_ref_xy",
    "ph_no_ref_z",
    "ph_no_adjustment",
    "ph_no_pan_ms",
    "ph_not_reproduced",
    "ph_no_overlaps_derived",  # before its shorter "no overlaps table (overlaps.csv) …"
    "ph_no_overlaps",
    "ph_no_edges",
    "ph_no_reported",
    "ph_no_scenes_bands",
    "ph_residuals_computed",
    "ph_computed_residuals",
    "ph_derived_overlaps",
    "ph_verified_residuals",
    "ph_no_observations_checked",
    "ph_on_other_bands",
    "ph_single_ray",
    "ph_observations_single_ray",
    "ph_bands",
    "ph_mostly_sea",
    "ph_water_fraction",
    "ph_not_recomputed",
    "ph_no_recomputation",
    "ph_nothing_to_recompute",
)
#: whole fixed texts of the results of rfm-accuracy, adjust and factors, each a catalogue key
#: whose English may hold {fields}: a text that is one of them, its fields' values translated in
#: turn, is shown in the page's language (Formatter.sentence); tried in this order, so that
#: "{note}; only {n} check CPs" is taken apart before its parts
SENTENCES = (
    "doc_not_declared",  # a document's problems: those naming a link before those they hold
    "doc_loop",
    "doc_outside",
    "doc_folder",
    "doc_dangling",
    "doc_not_regular",
    "doc_missing_case",
    "doc_missing_link",
    "doc_missing",
    "doc_empty",
    "doc_unreadable",
    "doc_invalid",
    "doc_not_utf8",
    "qe_not_scored",
    "qe_not_judged",
    "qe_norm_no_gsd",
    "qe_norm_problem",
    "ra_grid_again",
    "ad_prior_elsewhere",
    "ra_note_few_checks",
    "ra_note_collinear",
    "ra_converted",
    "ra_declared_by",
    "ra_stated_by_user",
    "ra_stated",
    "ra_how_ortho",
    "ra_how_reprojected",
    "ra_band_one",
    "ra_band_first",
    "ra_bands_rgb_of",
    "ra_bands_rgb",
    "ra_heights_ellipsoidal",
    "ra_heights_geoid",
    "ra_heights_constant",
    "ra_srtm",
    "ra_crs_2d",
    "ra_crs",
    "ra_no_crs",
    "ra_geoid_egm96",
    "ra_geoid_grid",
    "ra_geoid_constant",
    "ra_geoid_word",
    "ra_grid_given",
    "ra_grid_chosen",
    "ra_reading_text",
    "ra_model_affine",
    "ra_model_quadratic",
    "ra_model_none",
    "ra_evaluation",
    "ra_note_original",
    "ra_note_needs",
    "ra_note_refined",
    "ra_all_cps_note",
    "ra_convention_image",
    "ra_convention_gdal",
    "ra_convention_heights",
    "ra_warn_no_height",
    "ra_warn_outside_voids",
    "ra_warn_outside",
    "ra_warn_voids",
    "ra_warn_few_cps",
    "ra_grid_chosen_word",
    "ra_warn_dem_ellipsoid",
    "ra_warn_reference_gsd",
    "ra_warn_k_unsupported",
    "ra_warn_k_few_checks",
    "rc_convention",
    "rc_on_failed_geometry",
    "rc_sign_swapped",
    "rc_sign",
    "rc_swapped",
    "mb_straddles",
    "mb_edge_both",  # before its shorter "a zone edge (…)", which would take it whole
    "mb_edge_zone",
    "mb_edge_equator",
    "mb_wrong_zone",
    "mb_grid_exception",
    "mb_no_epsg",
    "mb_projection_named",
    "ad_affine_priors",
    "ad_prior_weak",
    "ad_prior_dem",
    "ad_producer_delivered",
    "ad_producer_none",
    "ad_producer_intersected",
    "ad_crs_block",
    "ad_crs_utm",
    "ad_crs_utm_not_metres",
    "ad_crs_ups",
    "ad_crs_ups_not_metres",
    "ad_cps_none",
    "ad_cps_few",
    "ad_warn_narrow_rays",
    "ad_warn_scene",
    "ad_warn_scene_empty",
    "ad_warn_left_out",
    "iw_stored_type_coarse",  # a table's ground columns stored coarser than float64
    "iw_stored_type",
    "ad_warn_scene_few",
    "ad_warn_sigma0",
    "ad_warn_datum",
    "ad_warn_prior_more",  # before the sentence that would read its ", and N more" as a name
    "ad_warn_prior",
    "ad_warn_all_held",
    "ad_warn_rms_grew",
    "af_factor",
    "af_indicator",
    "af_few_values",
    "af_constant",
    "af_nearly_constant",
    "af_needs_rows",
    "af_constant_group",
    "af_combination",
    "af_the_others",
    "af_collinear",
)
#: the sentences an evidence cell may be: a document's problem (§DOC-1)
CELL_SENTENCES = tuple(k for k in SENTENCES if k.startswith("doc_"))
_FIELD = re.compile(r"\{(\w+)\}")
_METHOD = r"(?:high_precision|same_accuracy|recalculation)"
_NO_METHOD = re.compile(rf"\bno ({_METHOD}) checkpoints\b")
_NO_METHODS = re.compile(rf"\bno checkpoints of the methods ({_METHOD}(?:, {_METHOD})*)")
#: units of a statistic written after its column label; counts name the column instead
SHOWN_UNITS = ("px", "m", "%", "degrees")
#: a cell holding a word longer than this wraps anywhere (long scene, point and block ids)
LONG_WORD = 24


#: fields of a sentence that hold one of other sentences (named here), so that the name before
#: them (a file, a scene) may hold spaces and brackets: "scene S 01 has no tie-point observation"
NESTED = {
    ("rc_convention", "convention"): ("rc_sign_swapped", "rc_sign", "rc_swapped"),
    ("ra_warn_no_height", "parts"): ("ra_warn_outside_voids", "ra_warn_outside", "ra_warn_voids"),
    ("ad_warn_scene", "why"): ("ad_warn_scene_empty", "ad_warn_scene_few"),
    ("qe_not_scored", "why"): ("qe_norm_no_gsd", "qe_norm_problem"),
}


@cache
def _sentence(key: str) -> re.Pattern[str]:
    """The English of `key` as a pattern, each {field} a group that takes any text: the least
    it can, but all it can when the text begins with it ("{note}; only {n} check CPs": the note
    up to the last "; ") or a NESTED sentence follows it; a field named again is the same text
    ("k = {k} needs more than {k}")."""
    return re.compile(_pattern(key), re.S)


@cache
def _pattern(key: str, named: bool = True) -> str:
    """`_sentence`'s pattern; not `named`, its groups do not capture (a sentence within one)."""
    parts = _FIELD.split(MESSAGES[key][0])
    return "".join(
        re.escape(p) if i % 2 == 0 else _field(key, p, parts[1:i:2], _greedy(key, parts, i), named)
        for i, p in enumerate(parts)
    )


def _greedy(key: str, parts: list[str], i: int) -> bool:
    """Whether the field `parts[i]` takes all it can: at the start of the text, or before a
    sentence NESTED names (known by its own words: the name before it, a file or a scene, is
    all the text up to them)."""
    return (i == 1 and not parts[0]) or (key, "".join(parts[i + 2 : i + 3])) in NESTED


def _field(key: str, name: str, before: list[str], greedy: bool, named: bool) -> str:
    """The pattern of the {field} `name` of `key`'s English, after the fields `before`: the same
    text as a field of that name before it, one of the sentences NESTED names, or any text."""
    if named and name in before:
        return f"(?P={name})"
    body = "|".join(_pattern(k, named=False) for k in NESTED.get((key, name), ()))
    body = body or f".+{'' if greedy else '?'}"
    return f"(?P<{name}>{body})" if named else f"(?:{body})"


def metric_units(metric: str | None) -> dict[str, str]:
    """Statistic -> unit, as the metric's scopes declare them (empty for an unknown metric)."""
    from blockqc.metrics import REGISTRY

    spec = REGISTRY.get(metric or "")
    if spec is None:
        return {}
    return {k: u for scope in spec.scopes.values() for k, u in scope.statistics.items()}


SYMBOLS = {"<=": "≤", "<": "<", ">=": "≥", ">": ">", "equals": "="}


def _bounds(threshold: Any) -> list[float]:
    """The numbers of a threshold (one bound, or the two of a range)."""
    values = threshold if isinstance(threshold, list) else [threshold]
    return [float(b) for b in values if isinstance(b, int | float) and not isinstance(b, bool)]


def _apart(v: float, text: str, bounds: list[float]) -> tuple[str, int]:
    """`text` (v shown) and the decimals of its bounds (`bound`), both with more decimals while
    they do not compare as v and the bounds do: a failing 0.1004 against ≤ 0.1 shows 0.1004, not
    0.100; a failing 14.1425 against ≤ √2·10 = 14.14214 shows 14.143 against ≤ 14.142, not 14.14
    against ≤ 14.14; beyond 6 decimals, to 12 significant digits."""
    digits, shown = 3 if abs(v) < 1 else 2, 2
    while not all(_same_order(v, b, text, bound(b, shown)) for b in bounds):
        if digits > MAX_DECIMALS:
            break
        digits = shown = max(digits, shown) + 1
        text = f"{v:.{digits}f}" if digits <= MAX_DECIMALS else f"{v:.12g}"
    return text, shown


def apart(v: Any, b: Any, digits: int = 2) -> tuple[str, str]:
    """A value and the bound it is judged against side by side (an accuracy m/m0), each to
    `digits` decimals, or to as many more as read them in the order they have: 14.1425 against
    √2·10 = 14.14214 reads 14.143/14.142, not 14.14/14.14; to 6 decimals at most."""
    shown = number(v, digits), number(b, digits)
    real = all(isinstance(x, int | float) and not isinstance(x, bool) for x in (v, b))
    if not real or not (math.isfinite(v) and math.isfinite(b)):
        return shown
    while digits < MAX_DECIMALS and not _same_order(v, b, *shown):
        digits += 1
        shown = f"{v:.{digits}f}", f"{b:.{digits}f}"
    return shown


def _same_order(v: float, b: float, text: str, shown: str) -> bool:
    """Whether the texts of v and of its bound b read as v and b compare (below, equal, above;
    a value within ON_BOUND of the bound's magnitude is on it, as the rules judge it)."""
    a, c = _reads(text), _reads(shown)
    if a is None or c is None:
        return True
    on = abs(v - b) <= ON_BOUND * abs(b)
    return (a > c) - (a < c) == (0 if on else (v > b) - (v < b))


def _reads(text: str) -> float | None:
    try:
        return float(text)
    except ValueError:
        return None


class Formatter:
    """The formatter of one language."""

    def __init__(self, lang: str, grades: Iterable[Any] = ()):
        self.lang = lang
        self.t = translator(lang)
        #: the pack's grades (id, title, title_zh), so that its own names are shown
        self.grades = {g.id: (g.title, g.title_zh) for g in grades}

    def _key(self, prefix: str, value: Any, fallback: str | None = None) -> str:
        key = f"{prefix}_{value}"
        return (
            self.t(key) if key in MESSAGES else (fallback if fallback is not None else str(value))
        )

    def score(self, v: float | None, missing: str = "–") -> str:
        """A score to one decimal, rounded down: 89.96 shows 89.9, never the 90.0 of a grade it
        does not reach (§QE-5 bounds are ≥ 90, 75, 60)."""
        if v is None or not math.isfinite(v):
            return missing
        return f"{math.floor(v * 10 + 1e-9) / 10:.1f}"

    def num(self, v: Any, digits: int | None = None) -> str:
        if isinstance(v, bool):
            return self.t("yes") if v else self.t("no")
        if isinstance(v, list | tuple):
            return ", ".join(self.num(x, digits) for x in v)
        if isinstance(v, dict):
            return ", ".join(f"{k}: {self.num(x, digits)}" for k, x in v.items())
        return number(v, digits)

    def unit(self, unit: str | None) -> str:
        return self._key("unit", unit, unit) if unit else ""

    def value(self, res: RuleResult) -> str:
        if res.value is None:
            return MISSING
        if isinstance(res.value, str):  # a named value: translated where the catalogue has it
            return self._key("val", res.value, self._key("status", res.value, res.value))
        text = self.num(res.value)
        if isinstance(res.value, float):
            text = _apart(res.value, text, _bounds(res.threshold))[0]
        unit = self.unit(res.unit)
        return f"{text} {unit}".strip() if unit and not isinstance(res.value, str) else text

    def threshold(self, res: RuleResult) -> str:
        comp, th = res.comparison, res.threshold
        if comp is None or th is None:
            return res.threshold_text or MISSING
        digits = 2  # more when the value beside it needs them to read apart (`_apart`)
        if isinstance(res.value, float):
            digits = _apart(res.value, self.num(res.value), _bounds(th))[1]
        if comp in SYMBOLS:
            shown = self.num(th) if isinstance(th, bool) else bound(th, digits)
            text = f"{SYMBOLS[comp]} {shown}"
        elif comp in ("between", "strictly_between") and isinstance(th, list) and len(th) == 2:
            dots = "…" if comp == "between" else "<…<"  # as the pack's threshold_text
            text = f"{bound(th[0], digits)} {dots} {bound(th[1], digits)}"
        elif comp == "in":
            names = th if isinstance(th, list) else [th]
            text = "∈ {" + ", ".join(self._key("val", v, self.num(v)) for v in names) + "}"
        else:
            return res.threshold_text or MISSING
        numeric = isinstance(th, int | float | list) and not isinstance(th, bool)
        unit = self.unit(res.unit)
        return f"{text} {unit}".strip() if numeric and unit else text

    @property
    def list_sep(self) -> str:
        """What separates the items of a list in the page's language: ", " in English, the
        enumeration comma "、" in Chinese."""
        return "、" if self.lang == "zh" else ", "

    @property
    def colon(self) -> str:
        """Before what a label introduces: "：" in Chinese, ": " in English."""
        return "：" if self.lang == "zh" else ": "

    @property
    def clause_sep(self) -> str:
        """Between the clauses of one line: "；" in Chinese, "; " in English."""
        return "；" if self.lang == "zh" else "; "

    def paren(self, text: Any) -> str:
        """A bracketed note after a text: "（m）" in Chinese, " (m)" in English."""
        return f"（{text}）" if self.lang == "zh" else f" ({text})"

    def join(self, items: Iterable[Any]) -> str:
        """The items of a list as the page's language writes one: 'TP-2, TP-4', 'TP-2、TP-4'."""
        return self.list_sep.join(str(x) for x in items)

    def group(self, group: dict[str, Any] | None) -> str:
        return " · ".join(self._key(k, v, str(v)) for k, v in (group or {}).items())

    def status(self, s: str | None) -> str:
        return self.t("not_checked") if s is None else self._key("status", s, s)

    def verdict(self, v: str) -> str:
        return self._key("verdict", v, v.upper())

    def title(self, res: RuleResult) -> str:
        return self.pick(res.title, res.title_zh) or res.rule

    def pick(self, en: str, zh: str) -> str:
        """A pack's text in the report's language (English when no translation is given)."""
        return zh if self.lang == "zh" and zh else en

    def column(self, key: str) -> str:
        return self._key("col", key, self.t(key) if key in MESSAGES else key)

    def evidence_column(self, key: str, units: dict[str, str]) -> str:
        """A column's label with the unit its metric declares: 'Median (px)', 'Observations'."""
        unit = units.get(key, "")
        if key == "n" and f"count_{unit}" in MESSAGES:
            return self.t(f"count_{unit}")
        label = self.column(key)
        if unit not in SHOWN_UNITS or label == key or label.endswith((")", "）")):
            return label
        shown = self.unit(unit)
        return label + self.paren(shown)

    def ident(self, values: Any) -> str:
        """'ident' (the class of cells that wrap anywhere) when a value holds a word longer than
        LONG_WORD characters (long scene, point or block ids), else ''."""
        texts = values if isinstance(values, list | tuple) else [values]
        return "ident" if any(len(w) > LONG_WORD for v in texts for w in str(v).split()) else ""

    def cell(self, v: Any) -> str:
        """An evidence value: named values (band pan, …), fixed phrases and sentences (a
        document's problem) translated."""
        if isinstance(v, str):
            said = self.sentence(v, CELL_SENTENCES)
            return self._key("val", v, said if said != v else self.text(v))
        return self.num(v)

    def text(self, s: str) -> str:
        """A text of results.json with its fixed English phrases in the page's language."""
        if self.lang == "en" or not s:
            return s
        for key in PHRASES:
            s = s.replace(MESSAGES[key][0], self.t(key))
        # "no high_precision checkpoints" (§CP: a method's rule with none of its points)
        s = _NO_METHOD.sub(lambda m: self.t("no_method_cps", method=self.method(m[1])), s)
        s = _NO_METHODS.sub(
            lambda m: self.t(
                "no_methods_cps", methods="、".join(self.method(x) for x in m[1].split(", "))
            ),
            s,
        )
        return s.replace("： ", "：")  # a full-width colon takes no space after it

    def sentence(self, s: str, keys: Iterable[str] = ()) -> str:
        """A fixed text of a run's results (SENTENCES, or those of `keys`) in the page's
        language, the values in it (numbers, file names, the texts nested in it) kept or
        translated in turn; others as they are."""
        if self.lang == "en" or not isinstance(s, str) or not s:
            return s
        for key in keys or SENTENCES:
            match = _sentence(key).fullmatch(s)
            if match:
                values = {k: self.sentence(v) for k, v in match.groupdict().items()}
                return self.t(key, **values)
        return s

    def sentences(self, s: str) -> str:
        """Fixed texts of a run's results joined by "; " (`sentence` each)."""
        if self.lang == "en" or not isinstance(s, str) or not s:
            return s
        return "；".join(self.sentence(part) for part in s.split("; "))

    def method(self, m: str) -> str:
        return self._key("method", m, m)

    def component(self, c: str) -> str:
        return self._key("component", c, c)
