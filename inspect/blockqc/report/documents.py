"""results.json and summary.json read back for `blockqc report`: strict JSON, the schema, and
what contradicts itself (a status its value and threshold do not make, counts that disagree)
or its companions (a summary that is not that of the results files named)."""

from __future__ import annotations

import json
import math
from collections.abc import Iterator
from pathlib import Path
from typing import Any, NamedTuple

from pydantic import ValidationError

from blockqc.errors import InputError, Problem
from blockqc.report.drawn import drawn_problems, is_number
from blockqc.results import (
    STATUSES,
    BlockEntry,
    BlockResults,
    RuleResult,
    Summary,
    block_fails,
    json_path,
    parse,
    tally,
)
from blockqc.rules.model import within
from blockqc.textio import dangling_link, not_there


class _NotJSON(ValueError):
    """NaN, Infinity or -Infinity: Python's json reads them, JSON has none."""


def _no_constant(name: str) -> Any:
    raise _NotJSON(name)


def _read_json(path: Path) -> tuple[Any, bytes]:
    from blockqc.textio import decode_utf8

    try:
        raw = path.read_bytes()
    except OSError as exc:
        raise InputError(Problem(str(path), f"cannot be read: {exc.strerror or exc}")) from None
    text = decode_utf8(path, raw)  # a byte-order mark, as some editors save, is read
    try:
        return json.loads(text, object_pairs_hook=_no_duplicates, parse_constant=_no_constant), raw
    except _DuplicateKey as exc:
        raise InputError(Problem(str(path), f"is not accepted: key '{exc}' given twice")) from None
    except _NotJSON as exc:
        raise InputError(
            Problem(
                str(path),
                f"is not accepted: {exc} is not JSON (blockqc writes a value that is not finite "
                "as null)",
            )
        ) from None
    except RecursionError:
        raise InputError(
            Problem(str(path), "is not accepted: JSON nested too deeply for a results document")
        ) from None
    except json.JSONDecodeError as exc:
        raise InputError(
            Problem(
                str(path), f"is not valid JSON: {exc.msg} (column {exc.colno})", line=exc.lineno
            )
        ) from None
    except ValueError as exc:  # e.g. an integer of more than 4300 digits
        raise InputError(Problem(str(path), f"is not accepted: {exc}")) from None


class _DuplicateKey(Exception):
    pass


def _no_duplicates(pairs: list[tuple[str, Any]]) -> dict[str, Any]:
    out: dict[str, Any] = {}
    for k, v in pairs:
        if k in out:
            raise _DuplicateKey(k)
        out[k] = v
    return out


def _strict(path: Path, doc: Any, kind: str) -> None:
    """The schema's types as they are: a number written as text ("3") is refused, not read."""
    model = BlockResults if kind == "results" else Summary
    try:
        model.model_validate(doc, strict=True)
    except ValidationError as exc:
        raise InputError(
            [
                Problem(str(path), f"not a valid {kind}.json: at {json_path(e['loc'])}: {msg}")
                for e in exc.errors()[:20]
                for msg in [_schema_says(e, model, kind)]
            ]
        ) from None


def _schema_says(err: Any, model: Any, kind: str) -> str:
    """A schema error in the project's words: a key the document's schema does not hold is an
    unknown key, with the key it resembles (a key misspelt, or one of another version)."""
    from blockqc.yamlio import known_key_hint

    if err["type"] != "extra_forbidden":
        return err["msg"]
    hint = known_key_hint(model, err["loc"])
    return f"unknown key{hint or f' (not in the schema of {kind}.json: blockqc schema {kind})'}"


def _contradictions(path: Path, doc: BlockResults) -> list[Problem]:
    """The verdict and the counts must be those of the rule results (as the engine makes them)."""
    if not doc.results:
        return [
            Problem(
                str(path),
                "$.results is empty: inspect gives every rule of its pack a "
                "result, so a block's results hold at least one",
            )
        ]
    counts, verdict = tally(r.status for r in doc.results)
    out = [
        Problem(
            str(path),
            f"$.counts.{s} is {doc.counts.get(s, 0)}, but {n} rule result(s) have status {s}",
        )
        for s, n in counts.items()
        if doc.counts.get(s, 0) != n
    ]
    if doc.verdict != verdict:
        out.append(
            Problem(
                str(path),
                f"$.verdict is {doc.verdict}, but its rule results make it {verdict} "
                f"({counts['error']} error, {counts['fail']} fail)",
            )
        )
    return out + [
        Problem(str(path), f"$.results[{i}] ({_named(r)}): {why}")
        for i, r in enumerate(doc.results)
        if (why := _misjudged(r))
    ]


def _named(r: RuleResult) -> str:
    """A result by its rule and group: `RO-3, component plane`."""
    return ", ".join([r.rule] + [f"{k} {v}" for k, v in r.group.items()])


#: the statuses of a value that does not meet its threshold (as the engine judges)
_NOT_MET = ("fail", "warn", "waived")


def _misjudged(r: RuleResult) -> str | None:
    """Why a result's status is not the one its value, threshold and severity make (None when
    it is, or when the result states no value to judge)."""
    met = meets(r.value, r.threshold, r.comparison)
    shown = f"its value {r.value!r} against {r.comparison} {r.threshold!r}"
    if met is False and r.status == "pass":
        return f"status pass, but {shown} does not meet the threshold"
    if met and r.status in _NOT_MET:
        return f"status {r.status}, but {shown} meets the threshold"
    if r.status == "warn" and r.severity != "warn":
        return f"status warn, but the rule's severity is {r.severity} (a failure fails the block)"
    if r.status == "fail" and r.severity == "warn" and r.comparison is not None:
        return "status fail, but the rule's severity is warn (a failure only warns)"
    return None


def meets(value: Any, threshold: Any, comparison: str | None) -> bool | None:
    """Whether a value meets a threshold as the engine judges it (`rules.model.within`); None
    when there is nothing to judge."""
    if value is None or comparison is None:
        return None
    if comparison == "equals":
        return bool(value == threshold)
    if comparison == "in":
        return isinstance(threshold, list) and value in threshold
    pair = threshold if isinstance(threshold, list) and len(threshold) == 2 else [None, None]
    lo, hi = {
        "<=": (None, threshold),
        "<": (None, threshold),
        ">=": (threshold, None),
        ">": (threshold, None),
        "between": pair,
        "strictly_between": pair,
    }.get(comparison, (None, None))
    if not is_number(value) or not any(is_number(b) for b in (lo, hi)):
        return None
    inclusive = comparison in ("<=", ">=", "between")
    lo, hi = (b if is_number(b) else None for b in (lo, hi))
    return bool(within(value, lo, hi, inclusive))


def _check_results(path: Path, doc: Any) -> BlockResults:
    """A results document to re-render: valid, its types strict, not contradicting itself."""
    _strict(path, doc, "results")
    results = parse(doc, str(path), "results")
    problems = _contradictions(path, results) + drawn_problems(path, results)
    problems += _evaluation_contradictions(path, results)
    if problems:
        raise InputError(problems)
    return results


def _evaluation_contradictions(path: Path, doc: BlockResults) -> list[Problem]:
    """The evaluation's figures must be those its items and elements make (§QE-2..5): a score
    edited would be shown as the block's, its grade and the batch decision drawn from it."""
    from blockqc.acceptance.scoring import recheck

    if doc.evaluation is None:
        return []
    found = recheck(doc.evaluation)
    if not found:
        found = _grade_contradiction(doc)
    return [Problem(str(path), f"$.evaluation.{at} is {why} (inspect again)") for at, why in found]


def _grade_contradiction(doc: BlockResults) -> list[tuple[str, str]]:
    """The grade an evaluation gives against the one its score and `fails` make by the grades
    of the pack that judged it (§QE-5), when that pack is found as it was."""
    ev = doc.evaluation
    assert ev is not None
    files = doc.rule_pack_files[:1]
    acc = next(_acceptances(doc.rule_pack, doc.rule_pack_version, files), None)
    if acc is None:
        return []
    made = acc.fail_grade if ev.fails else acc.grade(ev.score) if ev.score is not None else None
    if ev.grade == (made.id if made else None):
        return []
    why = f"fails (§QE-2), so {made.id}" if ev.fails else f"scores {ev.score}: {made and made.id}"
    return [("grade", f"{_json(ev.grade)}, but the block {why} by {doc.rule_pack}'s grades")]


def _check_summary(path: Path, doc: Any) -> Summary:
    _strict(path, doc, "summary")
    return parse(doc, str(path), "summary")


def _summary_blocks(
    path: Path, summary: Summary, named: list[Path]
) -> tuple[list[Path], list[Problem]]:
    """The results files of the summary's blocks not named already, and a problem for each
    block whose results file is missing: its report could not be re-made, nor linked to."""
    found: list[Path] = []
    missing: list[Problem] = []
    for b in summary.blocks:
        cand = path.parent / b.results
        if not cand.is_file():
            msg = (
                f"lists block {b.block_id}, but its results file {cand} is missing (name the "
                "results files to re-render without the summary)"
            )
            missing.append(Problem(str(path), msg))
        elif cand not in named and cand not in found:
            found.append(cand)
    return found, missing


def _once(files: list[Path]) -> tuple[list[Path], list[Path]]:
    """The files named, each once (by the file it is, however spelt), and those named again."""
    first: dict[Path, Path] = {}
    again: list[Path] = []
    for f in files:
        if f.resolve() in first:
            again.append(f)
        else:
            first[f.resolve()] = f
    return list(first.values()), list(dict.fromkeys(again))


class Gathered(NamedTuple):
    results: list[tuple[Path, BlockResults, bytes]]
    summary: tuple[Path, Summary, bytes] | None
    repeated: list[Path]  # named more than once: read once
    left_out: list[Path]  # results beside a summary that does not list their block
    unchecked: list[str] = []  # what of the summary could not be checked, and why


def gather(paths: list[Path]) -> Gathered:
    """The results documents named (files or folders holding them), a summary if any, the
    files named more than once (read once), and those left out: a folder with a summary gives
    the summary's blocks, another block's results there (a delivery since withdrawn) is not
    rendered."""
    named, beside = _named_files(paths)
    named, repeated = _once(named)
    files, loaded, summary, problems = _read_documents(named)
    results, refused = _checked_results(loaded)
    problems += refused
    unchecked: list[str] = []
    if summary is not None:
        by_file = {f.resolve(): d for f, d, _ in results}
        problems += _summary_contradictions(summary[0], summary[1], by_file, unchecked)
    if problems:
        raise InputError(problems)
    read = {f.resolve() for f in files}
    left_out = [f for f in beside if f.resolve() not in read]
    return Gathered(results, summary, repeated, left_out, unchecked)


def _named_files(paths: list[Path]) -> tuple[list[Path], list[Path]]:
    """The files the paths name (a folder: its results.json, else its summary.json or its
    */results.json), and the results beside a summary, read only when it lists them."""
    problems: list[Problem] = []
    files: list[Path] = []
    beside: list[Path] = []
    for p in paths:
        if p.is_dir():
            if links := _links_to_nothing(p):
                problems += links
            elif (p / "results.json").is_file():
                files.append(p / "results.json")
            else:
                found = sorted(p.glob("*/results.json"))
                if (p / "summary.json").is_file():
                    files.append(p / "summary.json")
                    beside += found
                    found = []
                elif not found:
                    problems.append(
                        Problem(
                            str(p), "holds no results.json (nor */results.json or summary.json)"
                        )
                    )
                files.extend(found)
        elif p.is_file():
            files.append(p)
        else:
            problems.append(Problem(str(p), not_there(p, "does not exist")))
    if problems:
        raise InputError(problems)
    return files, beside


def _links_to_nothing(folder: Path) -> list[Problem]:
    """The results.json, summary.json or */results.json of a folder given to `report` that are
    symbolic links to nothing, named with where they lead: they would be left out unsaid (a
    folder's results are found by name, and a link to nothing is no file)."""
    names = [folder / "results.json", folder / "summary.json"]
    names += [d / "results.json" for d in sorted(folder.iterdir()) if d.is_dir()]
    return [Problem(str(f), link) for f in names if (link := dangling_link(f))]


def _read_documents(
    named: list[Path],
) -> tuple[
    list[Path], list[tuple[Path, Any, bytes]], tuple[Path, Summary, bytes] | None, list[Problem]
]:
    """The files read (those named, then the summary's blocks not named), the results documents
    as read (not yet checked), the summary checked, and the problems met."""
    files = list(named)
    loaded: list[tuple[Path, Any, bytes]] = []
    summary: tuple[Path, Summary, bytes] | None = None
    problems: list[Problem] = []
    queue = list(files)
    while queue:
        f = queue.pop(0)
        try:
            doc, raw = _read_json(f)
        except InputError as exc:
            problems.extend(exc.problems)
            continue
        if isinstance(doc, dict) and "blocks" in doc and "results" not in doc:
            if summary is not None:
                problems.append(_second_summary(f, summary[0]))
                continue
            try:
                summary = (f, _check_summary(f, doc), raw)
            except InputError as exc:
                problems.extend(exc.problems)
                continue
            found, missing = _summary_blocks(f, summary[1], files)
            files += found
            queue += found
            problems += missing
            continue
        loaded.append((f, doc, raw))
    return files, loaded, summary, problems


def _checked_results(
    loaded: list[tuple[Path, Any, bytes]],
) -> tuple[list[tuple[Path, BlockResults, bytes]], list[Problem]]:
    """The results documents checked, each block once, and the problems met."""
    results: list[tuple[Path, BlockResults, bytes]] = []
    problems: list[Problem] = []
    seen: dict[str, Path] = {}
    for f, doc, raw in loaded:
        try:
            doc = _check_results(f, doc)
        except InputError as exc:
            problems.extend(exc.problems)
            continue
        bid = doc.block_id
        if bid in seen:
            if seen[bid].resolve() != f.resolve():
                problems.append(Problem(str(f), f"block_id {bid} is also the block of {seen[bid]}"))
            continue
        seen[bid] = f
        results.append((f, doc, raw))
    return results, problems


def _summary_contradictions(
    path: Path, summary: Summary, results: dict[Path, BlockResults], unchecked: list[str]
) -> list[Problem]:
    """The summary's counts must be those of its blocks, each block's id, verdict and counts
    those of the results file it names (as `inspect` writes them), and its batch decision the
    one they make; `results`: by real path; `unchecked`: what could not be checked, said."""
    blocks = summary.blocks
    out = _count_contradictions(path, summary)
    for b in blocks:
        r = results.get((path.parent / b.results).resolve())
        if r is not None:
            out += _block_contradictions(path, summary, b, r)
    out += _rule_count_contradictions(path, summary, list(results.values()))
    if out:  # the decision over blocks the summary does not describe would say so again
        return out
    made = [results.get((path.parent / b.results).resolve()) for b in blocks]
    if None in made:  # a block's results missing (refused) or unread: no decision to make
        return out
    return _acceptance_contradictions(path, summary, made, unchecked)


def _count_contradictions(path: Path, summary: Summary) -> list[Problem]:
    """The summary's counts, verdict and completeness against those its blocks make."""
    blocks = summary.blocks
    c = summary.counts
    expected = {
        "blocks": len(blocks) + len(summary.unreadable),
        "pass": sum(not block_fails(b.verdict) for b in blocks),
        "fail": sum(block_fails(b.verdict) for b in blocks),
        "error": sum(b.verdict == "error" for b in blocks),
        "unreadable": len(summary.unreadable),
    }
    given = c.model_dump(by_alias=True)  # blocks, pass, fail, error, unreadable
    out = [
        Problem(str(path), f"$.counts.{k} is {given[k]}, but its blocks make it {n}")
        for k, n in expected.items()
        if given[k] != n
    ]
    verdict = "error" if summary.unreadable else "fail" if expected["fail"] else "pass"
    if summary.verdict != verdict:
        out.append(
            Problem(
                str(path),
                f"$.verdict is {summary.verdict}, but its blocks make it {verdict} ("
                f"{expected['fail']} failing, {expected['unreadable']} unreadable)",
            )
        )
    complete = not summary.unreadable and all(b.complete and not b.pending_manual for b in blocks)
    if summary.complete != complete:
        out.append(
            Problem(
                str(path),
                f"$.complete is {str(summary.complete).lower()}, but its blocks make it "
                f"{str(complete).lower()} (complete unless a delivery is unreadable, a block "
                "incomplete or awaiting the inspector)",
            )
        )
    return out


def _block_contradictions(
    path: Path, summary: Summary, b: BlockEntry, r: BlockResults
) -> list[Problem]:
    """A block the summary lists against the results file it names: its id, the rule pack that
    judged it, its verdict and counts, then the rest of its line."""
    if r.block_id != b.block_id:
        return [
            Problem(
                str(path),
                f"lists block {b.block_id} with the results file {b.results}, which is block "
                f"{r.block_id}'s: the summary is not that of these results",
            )
        ]
    if (r.rule_pack, r.rule_pack_version) != (summary.rule_pack, summary.rule_pack_version):
        return [
            Problem(
                str(path),
                f"is of rule pack {summary.rule_pack} {summary.rule_pack_version}, but block "
                f"{b.block_id}'s results file {b.results} was judged by "
                f"{r.rule_pack} {r.rule_pack_version}: the summary is not that of these "
                "results",
            )
        ]
    counted = b.counts and any(b.counts.get(s, 0) != n for s, n in r.counts.items())
    if b.verdict != r.verdict or counted:
        return [
            Problem(
                str(path),
                f"lists block {b.block_id} as {b.verdict}, with counts {dict(b.counts)}, but "
                f"its results file says {r.verdict}, with {dict(r.counts)}: the summary is not "
                "that of these results (inspect again, or name the results files without "
                "the summary)",
            )
        ]
    return _entry_contradictions(path, b, r)


#: what the summary pages show of a block beside its verdict, as `inspect` makes it from the
#: block's results file
_ENTRY_FIELDS = (
    "failed_rules",
    "warned_rules",
    "pending_manual",
    "complete",
    "sampled",
    "checkpoints",
    "score",
    "grade",
    "evaluation_fails",
    "evaluation_reasons",
)


def _entry_contradictions(path: Path, b: BlockEntry, r: BlockResults) -> list[Problem]:
    """A block's line in the summary against the one its results file makes."""
    from blockqc.batch import block_entry

    made = block_entry(path, r, b.pdf)
    return [
        Problem(
            str(path),
            f"lists block {b.block_id} with {name} {_difference(given, getattr(made, name))}: "
            "the summary is not that of these results (inspect again, or name the results "
            "files without the summary)",
        )
        for name in _ENTRY_FIELDS
        if (given := getattr(b, name)) != getattr(made, name)
    ]


def _difference(given: Any, made: Any) -> str:
    """How a summary's field differs from the one the results file makes; rows of statistics
    by the first row and key that differ."""
    rows = [v for v in (given, made) if isinstance(v, list) and v and isinstance(v[0], dict)]
    if not rows:
        return f"{_json(given)}, but its results file makes it {_json(made)}"
    if len(rows) < 2 or len(given) != len(made):
        return f"of {len(given or [])} row(s), but its results file makes {len(made or [])}"
    i, g, m = next((i, g, m) for i, (g, m) in enumerate(zip(given, made, strict=True)) if g != m)
    key = next(k for k in dict.fromkeys([*m, *g]) if g.get(k) != m.get(k))
    return (
        f"[{i}] ({', '.join(str(m.get(k)) for k in ('component', 'method'))}) {key} "
        f"{_json(g.get(key))}, but its results file makes it {_json(m.get(key))}"
    )


def _json(value: Any) -> str:
    return json.dumps(value, ensure_ascii=False)


def _rule_count_contradictions(
    path: Path, summary: Summary, results: list[BlockResults]
) -> list[Problem]:
    """The summary's results per rule and status against its blocks' results files (a summary
    without them, `rules: {}`, shows none)."""
    if not summary.rules:
        return []
    made: dict[str, dict[str, int]] = {}
    for r in results:
        for x in r.results:
            made.setdefault(x.rule, dict.fromkeys(STATUSES, 0))[x.status] += 1
    out = []
    for rule in dict.fromkeys([*summary.rules, *made]):
        given = {s: summary.rules.get(rule, {}).get(s, 0) for s in STATUSES}
        counted = made.get(rule, dict.fromkeys(STATUSES, 0))
        if given != counted:
            wrong = ", ".join(f"{s} {given[s]}" for s in STATUSES if given[s] != counted[s])
            right = ", ".join(f"{s} {counted[s]}" for s in STATUSES if given[s] != counted[s])
            out.append(
                Problem(
                    str(path),
                    f"$.rules.{rule} counts {wrong}, but its blocks' results files hold "
                    f"{right}: the summary is not that of these results",
                )
            )
    return out


def _second_summary(path: Path, first: Path) -> Problem:
    """One summary is re-rendered per run: a second would replace the first unsaid."""
    return Problem(
        str(path),
        f"a second batch summary (the first: {first}): re-render one batch at a time, or name "
        "the results files without their summaries",
    )


#: the fields of the batch decision (`acceptance`) that `inspect` makes from the blocks' results
#: files, the pack's acceptance section and the plan; in the order the pages show them
_DECISION_FIELDS = (
    "decision",
    "sample_source",
    "sample",
    "failing",
    "incomplete",
    "mean_score",
    "sample_grade",
    "better_pct",
    "top_pct",
    "batch_grade",
    "returned",
    "blocks",
)

#: what of the decision depends on the pack's better_than, batch_grades and batch_default
_BY_BATCH_GRADES = ("better_pct", "batch_grade")


def _acceptance_contradictions(
    path: Path, summary: Summary, made: list[BlockResults], unchecked: list[str]
) -> list[Problem]:
    """The summary's batch decision against the one `inspect` makes (`decide`) from its blocks'
    results files (in the summary's order), the plan it records (`sampling.sampled`), its
    deliveries not read and its plan notes; the pack's acceptance section as the summary records
    it (`acceptance.grades`, `standard`) and, for the batch grade, the pack that judged them."""
    from blockqc.acceptance.decision import decide
    from blockqc.batch import graded

    given = summary.acceptance
    evaluated = [r.block_id for r in made if r.evaluation is not None]
    if given is None or (made and not evaluated):
        return _decision_left_out(path, given, evaluated)
    out: list[Problem] = []
    if len(given.unreadable) != len(summary.unreadable):
        out.append(
            Problem(
                str(path),
                f"$.acceptance.unreadable names {len(given.unreadable)} delivery(ies) "
                f"({', '.join(given.unreadable) or 'none'}), but $.unreadable lists "
                f"{len(summary.unreadable)}",
            )
        )
    planned = _planned(path, summary)
    if isinstance(planned, Problem):
        return [*out, planned]
    if len(given.grades) < 2:
        return [*out, Problem(str(path), "$.acceptance.grades lists no grade and fail grade")]
    acc = _pack_acceptance(summary, made)
    source = "checkpoints" if planned is None else "plan"
    grades = [g for r in made if (g := graded(r)) is not None]
    d = decide(grades, acc or _recorded_acceptance(summary), source, given.unreadable, planned)
    skip: tuple[str, ...] = ()
    if acc is None and d.decision == "pass":  # the batch grade is the pack's to make
        skip = _BY_BATCH_GRADES
        unchecked.append(
            f"{path}: the batch grade ({given.batch_grade}) and its share of units good or "
            f"better ({given.better_pct} %) are not checked against its blocks: rule pack "
            f"{summary.rule_pack} {summary.rule_pack_version} is not found as it judged them "
            "(at the file its blocks' results name, nor among the stock packs)"
        )
    return out + _decision_field_contradictions(path, given, d, skip)


def _decision_left_out(path: Path, given: Any, evaluated: list[str]) -> list[Problem]:
    """A summary without a batch decision whose blocks are evaluated (`evaluated`: their ids),
    or with one whose blocks are not (neither: a pack without `acceptance:`, no decision)."""
    if given is None:
        if not evaluated:
            return []  # a pack without `acceptance:` (asprs-2023): no decision to make
        return [
            Problem(
                str(path),
                "$.acceptance is null, but its blocks' results files are evaluated (block "
                f"{evaluated[0]}): the batch decision is left out (inspect again)",
            )
        ]
    return [
        Problem(
            str(path),
            "$.acceptance gives a batch decision, but none of its blocks' results files is "
            "evaluated (their pack has no acceptance section): the summary is not that of "
            "these results",
        )
    ]


def _decision_field_contradictions(
    path: Path, given: Any, made: Any, skip: tuple[str, ...]
) -> list[Problem]:
    """The fields of the summary's batch decision that differ from the decision its blocks
    make (those in `skip` left unchecked)."""
    out: list[Problem] = []
    for name in _DECISION_FIELDS:
        if name in skip:
            continue
        diff = _decision_difference(name, getattr(given, name), getattr(made, name))
        if diff:
            out.append(
                Problem(
                    str(path),
                    f"$.acceptance.{diff}: the summary's batch decision is not that of these "
                    "results (inspect again, or name the results files without the summary)",
                )
            )
    return out


def _planned(path: Path, summary: Summary) -> list[str] | None | Problem:
    """The plan's sampled blocks as the summary records the plan (None without a plan)."""
    if summary.sampling is None:
        return None
    sampled = summary.sampling.get("sampled")
    if not isinstance(sampled, list) or not all(isinstance(b, str) for b in sampled):
        return Problem(str(path), f"$.sampling.sampled is {_json(sampled)}: not block ids")
    return sampled


def _recorded_acceptance(summary: Summary) -> Any:
    """The pack's acceptance section as far as the summary records it: its grades, best first,
    the fail grade last, and its standard; not its batch grades (none: left unchecked)."""
    from blockqc.acceptance.model import Acceptance

    assert summary.acceptance is not None
    *grades, fail = summary.acceptance.grades
    return Acceptance.model_construct(
        standard=summary.acceptance.standard,
        grades=grades,
        fail_grade=fail,
        batch_grades=[],
        better_than=grades[-1].id,
        batch_default=grades[-1].id,
    )


def _pack_acceptance(summary: Summary, made: list[BlockResults]) -> Any:
    """The acceptance section of the pack that judged the blocks: its top file as the results
    files record it, else the stock pack of its name; None when neither is found, or either is
    not that pack as it was (another name or version, other grades or standard)."""
    given = summary.acceptance
    assert given is not None
    files = [r.rule_pack_files[0] for r in made if r.rule_pack_files]
    for acc in _acceptances(summary.rule_pack, summary.rule_pack_version, files):
        if [*acc.grades, acc.fail_grade] == given.grades and acc.standard == given.standard:
            return acc
    return None


def _acceptances(name: str, version: str, files: list[str]) -> Iterator[Any]:
    """The acceptance sections of the packs `name` `version` found: at the top files a run
    recorded (`files`), then the stock pack of that name (a pack since changed is none)."""
    from blockqc.errors import BlockqcError
    from blockqc.resources import rules_dir
    from blockqc.rules.loader import available_packs, read_pack

    refs = [Path(f) for f in files]
    if name in available_packs():
        refs.append(rules_dir() / f"{name}.yaml")
    for ref in dict.fromkeys(refs):
        if not ref.is_file():  # a file since moved, or a pipe the run read (--rules <(...))
            continue
        try:
            pack, problems = read_pack(ref)
        except (BlockqcError, OSError, ValueError):
            continue
        if pack is not None and not problems and pack.acceptance is not None:
            if (pack.name, pack.version) == (name, version):
                yield pack.acceptance


def _decision_difference(name: str, given: Any, made: Any) -> str | None:
    """How a field of the summary's batch decision differs from the one its blocks make; blocks
    by their ids, then by the first block and key that differ (None when they agree)."""
    if name in ("failing", "returned", "blocks"):
        g = [b.model_dump(mode="json") for b in given]
        m = [b.model_dump(mode="json") for b in made]
        if [b["block_id"] for b in g] != [b["block_id"] for b in m]:
            return (
                f"{name} lists {_json([b['block_id'] for b in g])}, but its blocks' results "
                f"files make it {_json([b['block_id'] for b in m])}"
            )
        for i, (gb, mb) in enumerate(zip(g, m, strict=True)):
            keys = dict.fromkeys([*mb, *gb])
            key = next((k for k in keys if not _same(gb.get(k), mb.get(k))), None)
            if key is not None:
                return (
                    f"{name}[{i}] ({mb['block_id']}) {key} is {_json(gb.get(key))}, but its "
                    f"results file makes it {_json(mb.get(key))}"
                )
        return None
    if _same(given, made):
        return None
    return f"{name} is {_json(given)}, but its blocks' results files make it {_json(made)}"


def _same(given: Any, made: Any) -> bool:
    """Equal, a float within the rounding of its JSON text."""
    if is_number(given) and is_number(made):
        return math.isclose(given, made, rel_tol=1e-9, abs_tol=1e-9)
    return bool(given == made)
