"""Rule cases: a rule's passing and failing examples, kept beside its pack and run on demand.

The cases of a pack file `NAME.yaml` live in the folder `NAME.cases/` beside it, one file per
rule, `NAME.cases/<RULE>.yaml` (or `.yml`):

    rule: TP-4
    cases:
      - name: 99 tie points on S1
        drop: {tie_points: [{where: {scene_id: S1}, keep_first: 99}]}   # edits (casebase.py)
        expect: fail                 # the rule's overall status over its results
        value: 99                    # optional: a result's value, evidence rows, detail keys
        evidence: [{scene_id: S1, n_points: 99}]

A case may also give `group` (judge only the results of that group), `verdicts` (the
inspector's file) and `pack` (a pack extending the one under test: constants, overrides …).
Each case is applied to the hand-computable base delivery and judged by the pack the case file
sits beside (`blockqc rules test PACK`).
"""

from __future__ import annotations

import math
import tempfile
from collections.abc import Callable, Iterator
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any, Literal

import yaml
from pydantic import BaseModel, ConfigDict, Field, PrivateAttr, ValidationError

from blockqc.errors import BlockqcError, Problem, RuleError
from blockqc.metrics import REGISTRY
from blockqc.rules.casebase import EditError, edited_tables, inside, write_delivery
from blockqc.rules.lint import did_you_mean
from blockqc.rules.model import Pack, Rule
from blockqc.yamlio import Text, line_of, load_yaml, pydantic_problems

#: the most severe status first: a rule's overall status over its results
Expect = Literal["error", "fail", "warn", "waived", "manual", "pass", "not_applicable"]
Scalar = str | float | bool | None


class _RowEdit(BaseModel):
    model_config = ConfigDict(extra="forbid")
    where: dict[str, Scalar | dict[str, Scalar | list[Scalar]]] = Field(default_factory=dict)
    any: list[dict[str, Scalar | dict[str, Scalar | list[Scalar]]]] = Field(default_factory=list)


class SetEdit(_RowEdit):
    values: dict[str, Scalar]


class DeriveEdit(_RowEdit):
    model_config = ConfigDict(extra="forbid", populate_by_name=True)
    column: str
    from_: str = Field(alias="from")
    add: float = 0.0
    times: float = 1.0


class DropEdit(_RowEdit):
    keep_first: int | None = Field(default=None, ge=0)


class Case(BaseModel):
    """One case: edits of the base delivery, and what the rule must then say."""

    model_config = ConfigDict(extra="forbid")
    name: Text
    expect: Expect
    manifest: dict[str, Any] = Field(default_factory=dict)
    set: dict[str, list[SetEdit]] = Field(default_factory=dict)
    derive: dict[str, list[DeriveEdit]] = Field(default_factory=dict)
    drop: dict[str, list[DropEdit]] = Field(default_factory=dict)
    append: dict[str, list[dict[str, Scalar]]] = Field(default_factory=dict)
    remove_tables: list[str] = Field(default_factory=list)
    files: dict[str, str | None] = Field(default_factory=dict)
    verdicts: dict[str, Any] = Field(default_factory=dict)
    pack: dict[str, Any] = Field(default_factory=dict)
    group: dict[str, Scalar] = Field(default_factory=dict)
    value: Any = None
    evidence: list[dict[str, Any]] | None = None
    detail: dict[str, Any] | None = None


class CaseFile(BaseModel):
    model_config = ConfigDict(extra="forbid")
    rule: str
    # anything the cases share through YAML anchors (e.g. the files of a delivery's geometry)
    shared: dict[str, Any] = Field(default_factory=dict)
    cases: list[Case] = Field(min_length=1)
    _data: Any = PrivateAttr(default=None)

    def line(self, i: int, *loc: Any) -> int | None:
        """The line where case `i` starts, or where its key `loc` stands."""
        return line_of(self._data, ("cases", i, *loc))

    def repeated_names(self, path: Path) -> list[Problem]:
        """A case named like an earlier one, at its name's line: the outcomes could not be told
        apart."""
        first: dict[str, int] = {}
        out = []
        for i, case in enumerate(self.cases):
            if case.name not in first:
                first[case.name] = i
                continue
            j = first[case.name]
            out.append(
                Problem(
                    str(path),
                    f"cases.{i}.name: '{case.name}' is also the name of cases.{j} (line "
                    f"{self.line(j, 'name')}): give each case a name of its own",
                    line=self.line(i, "name"),
                )
            )
        return out


@dataclass
class Outcome:
    """The result of one case."""

    file: Path
    line: int | None
    rule: str
    name: str
    ok: bool
    message: str = ""
    skipped: bool = False  # a case of a rule the pack disables: not run (lint accepts it)


def case_folder(pack_file: Path) -> Path:
    """`NAME.cases/` beside the pack file `NAME.yaml`."""
    return pack_file.with_name(pack_file.stem + ".cases")


#: the suffixes a case file may have
CASE_SUFFIXES = (".yaml", ".yml")
#: what a cases folder may hold beside its case files, left unread: a README saying what the
#: cases are for (README, README.md, README.txt, in any case)
NOTE_SUFFIXES = ("", ".md", ".txt")


def _is_readme(entry: Path) -> bool:
    return entry.is_file() and entry.stem.upper() == "README" and entry.suffix in NOTE_SUFFIXES


def _stray(entry: Path) -> Problem:
    """The problem of an entry of a cases folder that is not a case file."""
    kind = "a folder" if entry.is_dir() else "a file" if entry.is_file() else "not a file"
    if entry.suffix in CASE_SUFFIXES:
        return Problem(str(entry), f"{kind}: expected a case file (YAML) for rule {entry.stem}")
    return Problem(
        str(entry),
        f"not a case file ({kind}): expected <RULE>.yaml or <RULE>.yml, one per rule of the "
        "pack (beside them only a README is left unread)",
    )


def case_files(folder: Path) -> list[Path]:
    """Every case file of a cases folder (`.yaml` or `.yml`), sorted; none when the folder does
    not exist.

    RuleError, listing every problem, for what would otherwise be passed over unsaid: a
    `NAME.cases` that is a file, not a folder; an entry named like a case file that is not a
    file (a folder `TP-1.yaml/`); any other entry (`notes.txt`, `TP-1.YAML`, a sub-folder),
    refused as a case file of a rule the pack does not have is; a rule with both a `.yaml`
    and a `.yml` file, since either could be the one meant. A README (README, README.md or
    README.txt) is documentation, not an input: it is left unread, as are hidden entries
    (`.gitkeep`, an editor's swap file), which a folder listing does not show either."""
    if not folder.exists():
        return []
    if not folder.is_dir():
        raise RuleError(
            Problem(
                str(folder),
                "a file: expected the folder of the pack's cases, holding <RULE>.yaml files (one "
                "per rule)",
            )
        )
    entries = sorted(f for f in folder.iterdir() if not f.name.startswith("."))
    files = [f for f in entries if f.suffix in CASE_SUFFIXES and f.is_file()]
    problems = [_stray(f) for f in entries if f not in files and not _is_readme(f)]
    stems = [f.stem for f in files]
    problems += [
        Problem(str(f), f"cases for {f.stem} also in {f.stem}.yaml: keep one")
        for f in files
        if stems.count(f.stem) > 1 and f.suffix == ".yml"
    ]
    if problems:
        raise RuleError(problems)
    return files


def find_case_file(chain: list[str], rule_id: str) -> Path | None:
    """The case file of a rule nearest to the pack: its own folder first, then its parents'."""
    for file in chain:
        found = [f for f in case_files(case_folder(Path(file))) if f.stem == rule_id]
        if found:
            return found[0]
    return None


def read_case_file(path: Path) -> CaseFile:
    """Read and validate a case file; problems name the file and line."""
    data = load_yaml(path, RuleError)
    try:
        doc = CaseFile.model_validate(data)
    except ValidationError as exc:
        raise RuleError(pydantic_problems(exc, path, data, model=CaseFile)) from None
    if doc.rule != path.stem:
        line = line_of(data, ("rule",))
        raise RuleError(
            Problem(str(path), f"rule: {doc.rule}, but the file is {path.name}", line=line)
        )
    doc._data = data
    repeated = doc.repeated_names(path)
    if repeated:
        raise RuleError(repeated)
    return doc


def case_problems(path: Path, doc: CaseFile, pack: Pack, pack_file: Path) -> list[Problem]:
    """What the cases of a file ask that their rule can never give — a `value` of another kind
    than the rule's statistic, a `group` column or value the rule does not judge, an evidence
    column or detail key its results do not have — by file and line. Each case is checked
    against the rule it runs under: the pack's, or its own `pack:`'s."""
    out: list[Problem] = []
    with tempfile.TemporaryDirectory(prefix="blockqc-case-") as tmp:
        for i, case in enumerate(doc.cases):

            def bad(message: str, *loc: Any, i: int = i) -> None:
                where = ".".join(map(str, ("cases", i, *loc)))
                out.append(Problem(str(path), f"{where}: {message}", line=doc.line(i, *loc)))

            _check_edits(case, Path(tmp), bad)
            case_pack = _case_rule_pack(pack, pack_file, doc.rule, case, Path(tmp), bad)
            if case_pack is None:
                continue
            rule = case_pack.rule(doc.rule)
            out.extend(_verdict_problems(path, doc, i, case_pack))
            _check_value(case.value, rule, bad)
            _check_group(case.group, rule, bad)
            _check_evidence(case.evidence, rule, bad)
            _check_detail(case.detail, rule, bad)
    return out


def _check_edits(case: Case, work: Path, bad: Callable[..., None]) -> None:
    """A case's edits made on the base tables (no delivery written): an unknown table, column
    or comparison, a selection of no row, a file outside the delivery."""
    edits = _plain(case.model_dump(by_alias=True, exclude_none=True))
    try:
        edited_tables(edits)
        for rel in edits.get("files") or {}:
            inside(work / "delivery", rel)
    except EditError as exc:
        bad(f"cannot be made on the base delivery: {exc}")


def _case_rule_pack(
    pack: Pack, pack_file: Path, rule_id: str, case: Case, work: Path, bad: Callable[..., None]
) -> Pack | None:
    """The pack a case is judged by; None when its own `pack:` cannot be read or disables the
    rule (reported at the case's `pack` key: the pack is written to a file of the moment)."""
    try:
        case_pack = _case_pack(pack, pack_file, case, work)
        case_pack.rule(rule_id)
        return case_pack
    except KeyError:
        bad(f"disables {rule_id}, the rule the cases are for", "pack")
    except BlockqcError as exc:
        for p in exc.problems:
            bad(p.message, "pack")
    return None


def _verdict_problems(path: Path, doc: CaseFile, i: int, pack: Pack) -> list[Problem]:
    """A case's `verdicts`, checked as inspect checks an inspector's file: verdicts for manual
    rules of the pack, waivers of waivable ones (its scenes are checked where the case runs)."""
    from blockqc.errors import InputError
    from blockqc.inspector import InspectorInput, check_inspector_input

    at = ("cases", i, "verdicts")
    try:
        inp = InspectorInput.model_validate(doc.cases[i].verdicts)
    except ValidationError as exc:
        return pydantic_problems(exc, path, doc._data, at, model=InspectorInput)
    inp._file, inp._data = str(path), doc._data["cases"][i].get("verdicts")
    try:
        check_inspector_input(inp, {r.id: r for r in pack.rules}, {"CASE": None})
    except InputError as exc:
        return [Problem(p.file, f"{_key(at)}: {p.message}", line=p.line) for p in exc.problems]
    return []


def _key(loc: tuple[Any, ...]) -> str:
    return ".".join(map(str, loc))


def _statistic_unit(rule: Rule) -> str:
    return REGISTRY[rule.metric or ""].scopes[rule.scope].statistics.get(rule.statistic or "", "")


def _check_value(value: Any, rule: Rule, bad: Callable[..., None]) -> None:
    """A case's `value` is of the kind the rule's statistic gives: a number, true/false, a text."""
    if value is None or rule.manual:
        return
    unit = _statistic_unit(rule)
    if unit == "true/false":
        ok, want = isinstance(value, bool), "true or false"
    elif unit == "name":
        ok, want = isinstance(value, str), "a text"
    elif unit:
        ok = isinstance(value, (int, float)) and not isinstance(value, bool)
        want = "a number"
    else:
        return
    judged = f"rule {rule.id} judges {rule.statistic} ({unit})"
    if not ok:
        bad(f"{judged}: expected {want}, got {_kind(value)}", "value")
    elif isinstance(value, float) and not math.isfinite(value):
        # a result's value is a finite number or none: such a case could never pass
        bad(f"{judged}: expected a finite number, got {value} (which no result gives)", "value")


def _kind(value: Any) -> str:
    if isinstance(value, str):
        return f"the text '{value}'"
    if isinstance(value, bool):
        return str(value).lower()
    if isinstance(value, dict):
        return "a mapping"
    return "a list" if isinstance(value, list) else repr(value)


def _check_group(group: dict[str, Any], rule: Rule, bad: Callable[..., None]) -> None:
    """A case's `group` names group columns of the rule's scope and values the rule judges."""
    if not group:
        return
    scope = None if rule.manual else REGISTRY[rule.metric or ""].scopes[rule.scope]
    if scope is None or not scope.groups:
        what = f"{rule.metric} at scope {rule.scope}" if scope else "the inspector's verdict"
        bad(f"rule {rule.id} judges no groups ({what}): leave group out", "group")
        return
    for col, val in group.items():
        if col not in scope.groups:
            hint = did_you_mean(str(col), scope.groups)
            columns = ", ".join(scope.groups)
            bad(
                f"rule {rule.id} has no group column '{col}'{hint} (group columns: {columns})",
                "group",
                col,
            )
        elif col in rule.where and str(val) != str(rule.where[col]):
            bad(f"rule {rule.id} judges {col} {rule.where[col]} only (where:)", "group", col)
        elif str(val) not in scope.groups[col]:
            values = scope.groups[col]
            hint = did_you_mean(str(val), values)
            bad(
                f"rule {rule.id} has no {col} '{val}'{hint} (values: {', '.join(values)})",
                "group",
                col,
            )


def _check_evidence(
    evidence: list[dict[str, Any]] | None, rule: Rule, bad: Callable[..., None]
) -> None:
    """A case's `evidence` rows name columns the rule's evidence has: the units of its scope
    (scenes, pairs, points), else the rows of its `evidence_from` scope (a misspelt `scene`
    for `scene_id` matches no row, and the case would fail whatever the rule gives)."""
    if not evidence:
        return
    scopes = {} if rule.manual else REGISTRY[rule.metric or ""].scopes
    name = rule.scope if scopes and scopes[rule.scope].keys else rule.evidence_from
    if name is None:
        why = "the inspector's verdict" if rule.manual else f"judged at scope {rule.scope}"
        bad(f"rule {rule.id} lists no evidence ({why}, no evidence_from)", "evidence")
        return
    columns = scopes[name].all_columns()
    for j, row in enumerate(evidence):
        for key in row:
            if key not in columns:
                hint = did_you_mean(str(key), columns)
                bad(
                    f"rule {rule.id}'s evidence ({rule.metric} at scope {name}) has no column "
                    f"'{key}'{hint} (columns: {', '.join(columns)})",
                    "evidence",
                    j,
                    key,
                )


def _check_detail(detail: dict[str, Any] | None, rule: Rule, bad: Callable[..., None]) -> None:
    """A case's `detail` names keys the rule's results give (a misspelt `n_offendng` is in no
    result's detail, and the case would fail whatever the rule gives)."""
    from blockqc.engine import detail_keys

    keys = detail_keys(rule)
    what = "the inspector's verdict" if rule.manual else f"{rule.metric} at scope {rule.scope}"
    for key in detail or {}:
        if key == rule.statistic:
            why = f"{key} is the statistic rule {rule.id} judges: give it as the case's value"
        elif key not in keys:
            hint = did_you_mean(str(key), keys)
            why = f"rule {rule.id}'s detail ({what}) has no key '{key}'{hint}"
        else:
            continue
        bad(f"{why} (keys: {', '.join(keys)})", "detail", key)


def aggregate_status(results: list[dict[str, Any]]) -> str:
    """A rule's overall status: the most severe over its results."""
    from blockqc.results import worst_status

    return worst_status(r["status"] for r in results) or "none"


def matches(expected: Any, actual: Any) -> bool:
    """`expected` is found in `actual`: mappings by their keys, lists item by item, numbers
    to 1e-8 relative."""
    if isinstance(expected, dict):
        return isinstance(actual, dict) and all(
            k in actual and matches(v, actual[k]) for k, v in expected.items()
        )
    if isinstance(expected, list):
        return isinstance(actual, list) and all(
            any(matches(e, a) for a in actual) for e in expected
        )
    if isinstance(expected, float) and isinstance(actual, (int, float)):
        return math.isclose(expected, actual, rel_tol=1e-8, abs_tol=1e-9)
    return expected == actual


def _judge(case: Case, results: list[dict[str, Any]]) -> str:
    """'' when the rule's results meet the case's expectations, else what differs."""
    chosen = [r for r in results if not case.group or matches(case.group, r["group"])]
    status = aggregate_status(chosen)
    if status != case.expect:
        got = "; ".join(f"{r['group'] or ''} {r['status']} {r['value']!r}".strip() for r in chosen)
        return f"expected {case.expect}, got {status} ({got or 'no result'})"
    if case.value is not None:
        values = [r["value"] for r in chosen if r["status"] == status]
        if not any(matches(case.value, v) for v in values):
            return f"expected value {case.value!r}, got {values!r}"
    if case.evidence is not None:
        evidence = [e for r in chosen for e in r["evidence"]]
        if not matches(case.evidence, evidence):
            return f"expected evidence {case.evidence!r}, got {evidence[:5]!r}"
    if case.detail is not None and not any(matches(case.detail, r["detail"]) for r in chosen):
        return f"expected detail {case.detail!r}, got {[r['detail'] for r in chosen]!r}"
    return ""


def _plain(value: Any) -> Any:
    """Plain dicts and lists (as read from YAML, with line numbers dropped)."""
    if isinstance(value, dict):
        return {k: _plain(v) for k, v in value.items()}
    if isinstance(value, list):
        return [_plain(v) for v in value]
    return value


def _case_pack(pack: Pack, pack_file: Path, case: Case, folder: Path) -> Pack:
    """The pack a case is judged by: the pack, or a pack extending it with `case.pack`."""
    from blockqc.rules.loader import load_pack

    if not case.pack:
        return pack
    extends = str(pack_file.resolve())
    extra = {"pack": "case-pack", "version": "1", **_plain(case.pack), "extends": extends}
    path = folder / "case-pack.yaml"
    path.write_text(yaml.safe_dump(extra, sort_keys=False, allow_unicode=True), "utf-8")
    return load_pack(path)


def run_case(pack: Pack, pack_file: Path, rule_id: str, case: Case, work: Path) -> str:
    """Apply one case to the base delivery, inspect it with the pack, say what differs ('')."""
    from blockqc.delivery import block_ids, load_delivery
    from blockqc.engine import inspect_delivery
    from blockqc.inspector import InspectorInput, check_inspector_input
    from blockqc.results import dump

    edits = _plain(case.model_dump(by_alias=True, exclude_none=True))
    folder = write_delivery(work / "delivery", edits)
    pack = _case_pack(pack, pack_file, case, work)
    inspector = InspectorInput.model_validate(case.verdicts)
    delivery = load_delivery(folder)
    # as inspect does: a waiver of a scene or unit the case's delivery lacks is refused, not
    # passed over (the case would fail, or pass, with the waiver read by nothing)
    check_inspector_input(inspector, {r.id: r for r in pack.rules}, *block_ids([folder]))
    doc = dump(inspect_delivery(delivery, pack, inspector.for_block("CASE")))
    results = [r for r in doc["results"] if r["rule"] == rule_id]
    if not results:
        return f"rule {rule_id} gave no result"
    return _judge(case, results)


def iter_cases(pack_file: Path) -> Iterator[tuple[Path, CaseFile, int, Case]]:
    """Every case beside one pack file: (case file, its document, case index, case)."""
    for f in case_files(case_folder(pack_file)):
        doc = read_case_file(f)
        for i, case in enumerate(doc.cases):
            yield f, doc, i, case


def run_file_cases(pack_file: Path) -> list[Outcome]:
    """Run the cases beside one pack file against that pack; a broken case raises RuleError."""
    from blockqc.rules.loader import load_pack

    pack = load_pack(pack_file)
    ids = {r.id for r in pack.rules}
    out = []
    for f, doc, i, case in iter_cases(pack_file):
        line = doc.line(i)
        if doc.rule in pack.disabled and doc.rule not in ids:
            why = f"not run: the pack disables {doc.rule}"
            out.append(Outcome(f, line, doc.rule, case.name, True, why, skipped=True))
            continue
        if doc.rule not in ids:
            raise RuleError(Problem(str(f), f"cases for {doc.rule}: no such rule in the pack"))
        if i == 0 and (problems := case_problems(f, doc, pack, pack_file)):
            raise RuleError(problems)
        with tempfile.TemporaryDirectory(prefix="blockqc-case-") as tmp:
            try:
                message = run_case(pack, pack_file, doc.rule, case, Path(tmp))
            except (EditError, ValidationError, BlockqcError) as exc:
                raise RuleError(
                    Problem(str(f), f"case '{case.name}': {_text(exc, Path(tmp))}", line=line)
                ) from None
        out.append(Outcome(f, line, doc.rule, case.name, not message, message))
    return out


def _text(exc: Exception, work: Path) -> str:
    """What stopped a case, a file of the delivery it made named by its name in the delivery
    (`block.yaml`), not by the temporary folder that is gone once the case has run, nor by a
    line of a file the user did not write."""
    if not isinstance(exc, BlockqcError):
        return str(exc).replace("\n", " ")
    made = str(work / "delivery") + "/"
    return "; ".join(
        str(replace(p, file=f"the case's {p.file.removeprefix(made)}", line=None))
        if p.file.startswith(made)
        else str(p)
        for p in exc.problems
    )


def run_pack_cases(pack: Pack, own_only: bool = False) -> list[Outcome]:
    """Run the cases of a pack and, unless `own_only`, those of the packs it extends."""
    files = pack.chain[:1] if own_only else pack.chain
    return [o for f in files for o in run_file_cases(Path(f))]
