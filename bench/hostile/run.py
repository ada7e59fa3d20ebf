"""The hostile campaign of issue #38: every case as data, each run and classified by its verdict.

Usage: ``python bench/hostile/run.py [--cases bench/hostile/cases.json] [--jobs 2] [--only ID]
[--sample N] [--work DIR] [--summary FILE]``

Each case (``cases.json``, written by ``make_cases.py``) is a ``bubblerob`` command line
(``argv``) or a Python snippet (``python``) and what it must do (``expect``):

- ``refuse``: exit non-zero (``exit`` if given: 2 for a usage error) with exactly one line
  ``bubblerob CMD: ...`` on standard error (a snippet: one line naming the ``ValueError`` or
  ``TypeError``), and ``stderr_has`` in it;
- ``ok``: exit 0, ``stdout_has`` printed and ``stdout_lacks`` not (a snippet: no failed assert);
- ``na``: a figure that cannot be computed: ``n/a`` printed, exit non-zero.

A case may write ``earlier`` files (path: text) into its folder first, as an earlier run left
them: each ``unchanged`` one must still hold its text afterwards, each ``replaced`` one must not
(``absent`` ones must be gone); otherwise the case is silently wrong.

Verdicts: ``ok`` (as promised), ``silently wrong`` (exit 0 where a refusal or ``n/a`` was due, or
a check of the output failed), ``bad refusal`` (refused, but not in one line, or with another exit
status), ``refused valid`` (a valid case refused), ``traceback``, ``crash`` (killed by a
signal), ``hang`` (past ``timeout``). Every case runs in a fresh folder (``{tmp}``) with no
display; ``{NAME}`` in an argv or snippet is fixture NAME (``fixtures.py``). Prints the totals by
verdict and each case that is not ``ok``; writes them all to ``--summary`` (JSON); exits 1 if any
case is not ``ok``.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time
from collections import Counter
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path
from typing import Any

HERE = Path(__file__).resolve().parent
ROOT = HERE.parents[1]
PYTHON = sys.executable


def _fill(text: str, fixtures: dict[str, str], tmp: Path) -> str:
    for name, path in {**fixtures, "tmp": str(tmp)}.items():
        text = text.replace("{" + name + "}", path)
    return text


def _command(case: dict[str, Any], fixtures: dict[str, str], tmp: Path) -> list[str]:
    argv = [_fill(a, fixtures, tmp) for a in case["argv"]]
    return [PYTHON, "-m", "bubblerob_cli", *argv]


def _environment() -> dict[str, str]:
    """No display, and this checkout first on the path."""
    env = {k: v for k, v in os.environ.items() if k not in ("DISPLAY", "WAYLAND_DISPLAY")}
    env["PYTHONPATH"] = str(ROOT)
    return env


def _launch(case: dict[str, Any], command: list[str], tmp: Path) -> tuple[int | None, str, str]:
    env = _environment()
    stdout: Any = subprocess.PIPE
    if case.get("stdout") == "full":
        stdout = open("/dev/full", "w")  # noqa: SIM115 - closed below
    close = case.get("stdout") == "closed"
    try:
        done = subprocess.run(
            command,
            cwd=tmp,
            env=env,
            stdout=stdout,
            stderr=subprocess.PIPE,
            text=True,
            timeout=case.get("timeout", 180),
            preexec_fn=(lambda: os.close(1)) if close else None,  # noqa: PLW1509
        )
    except subprocess.TimeoutExpired:
        return None, "", ""
    finally:
        if stdout is not subprocess.PIPE:
            stdout.close()
    return done.returncode, done.stdout or "", done.stderr


def _refusal_lines(case: dict[str, Any], stderr: str) -> list[str]:
    prefix = "refused: " if "python" in case else "bubblerob "
    return [line for line in stderr.splitlines() if line.startswith(prefix)]


def _earlier_files_wrong(case: dict[str, Any], tmp: Path) -> list[str]:
    """The ``unchanged`` files that changed and the ``replaced`` ones that did not."""
    earlier = {path: text.encode() for path, text in case.get("earlier", {}).items()}

    def holds(path: str) -> bool:
        return (tmp / path).is_file() and (tmp / path).read_bytes() == earlier[path]

    wrong = [path for path in case.get("unchanged", []) if not holds(path)]
    return wrong + [path for path in case.get("replaced", []) if holds(path)]


def classify(case: dict[str, Any], rc: int | None, out: str, err: str, tmp: Path) -> str:
    """The case's verdict (see the module docstring)."""
    if rc is None:
        return "hang"
    if "Traceback (most recent call last)" in err:
        return "traceback"
    if rc < 0 or rc in (134, 136, 137, 139):
        return "crash"
    expect = case["expect"]
    if rc == 4 and "python" in case:
        return "silently wrong"
    if expect == "ok":
        if rc != 0:
            return "refused valid"
        wrong = [s for s in case.get("stdout_has", []) if s not in out]
        wrong += [s for s in case.get("stdout_lacks", []) if s in out]
        wrong += [p for p in case.get("absent", []) if (tmp / p).exists()]
        wrong += _earlier_files_wrong(case, tmp)
        return "silently wrong" if wrong else "ok"
    if rc == 0:
        return "silently wrong"
    if expect == "na":
        return "ok" if "n/a" in out + err else "bad refusal"
    lines = _refusal_lines(case, err)
    if len(lines) != 1 or rc != case.get("exit", rc) or rc == 3:
        return "bad refusal"
    if any(s not in lines[0] for s in case.get("stderr_has", [])):
        return "bad refusal"
    if any((tmp / p).exists() for p in case.get("absent", [])) or _earlier_files_wrong(case, tmp):
        return "silently wrong"
    return "ok"


def _folder(case: dict[str, Any], work: Path) -> Path:
    tmp = work / "cases" / str(case["id"])
    if tmp.exists():
        subprocess.run(["rm", "-rf", str(tmp)], check=True)
    tmp.mkdir(parents=True)
    return tmp


def _result(case: dict[str, Any], rc: int | None, out: str, err: str, tmp: Path) -> dict[str, Any]:
    return {
        "id": case["id"],
        "kind": case.get("kind"),
        "verdict": classify(case, rc, out, err, tmp),
        "rc": rc,
        "stdout_tail": out[-300:],
        "stderr_tail": err[-400:],
    }


def run_case(case: dict[str, Any], fixtures: dict[str, str], work: Path) -> dict[str, Any]:
    """Run one command-line case in a fresh folder under ``work``; its verdict and output."""
    tmp = _folder(case, work)
    for path, text in case.get("earlier", {}).items():  # what an earlier run left there
        (tmp / path).parent.mkdir(parents=True, exist_ok=True)
        (tmp / path).write_text(text)
    rc, out, err = _launch(case, _command(case, fixtures, tmp), tmp)
    return _result(case, rc, out, err, tmp)


def run_snippets(
    cases: list[dict[str, Any]], fixtures: dict[str, str], work: Path
) -> list[dict[str, Any]]:
    """Run Python cases in one process (``snippets.py``); one the process died in is a crash."""
    folders = {case["id"]: _folder(case, work) for case in cases}
    lines = [
        json.dumps({"id": c["id"], "code": _fill(c["python"], fixtures, folders[c["id"]])})
        for c in cases
    ]
    timed_out = False
    try:
        done = subprocess.run(
            [PYTHON, str(HERE / "snippets.py")],
            input="\n".join(lines) + "\n",
            env=_environment(),
            capture_output=True,
            text=True,
            timeout=60 + 30 * len(cases),
            cwd=work,
        )
        answers = [json.loads(line) for line in done.stdout.splitlines() if line.startswith("{")]
    except subprocess.TimeoutExpired:
        answers, timed_out = [], True
    by_id = {a["id"]: a for a in answers}
    results = []
    for case in cases:
        answer = by_id.get(
            case["id"], {"rc": None if timed_out else -1, "stdout": "", "stderr": ""}
        )
        results.append(
            _result(case, answer["rc"], answer["stdout"], answer["stderr"], folders[case["id"]])
        )
    return results


def load_cases(path: Path, only: str | None = None, sample: int | None = None) -> list[Any]:
    """The cases of ``path``: those whose id starts with ``only``; every k-th for ``sample``."""
    cases = json.loads(path.read_text())
    if only:
        cases = [c for c in cases if c["id"].startswith(only)]
    if sample:
        cases = cases[:: max(1, len(cases) // sample)][:sample]
    return list(cases)


def fixtures_in(work: Path) -> dict[str, str]:
    """Make the fixtures (in a process of their own, as a user's session would).

    One folder per commit of this checkout: bags recorded by another version of the env need
    not replay in this one.
    """
    head = subprocess.run(
        ["git", "rev-parse", "--short", "HEAD"], cwd=ROOT, capture_output=True, text=True
    ).stdout.strip()
    done = subprocess.run(
        [PYTHON, str(HERE / "fixtures.py"), str(work / f"fixtures-{head or 'here'}")],
        env={**os.environ, "PYTHONPATH": str(ROOT)},
        capture_output=True,
        text=True,
        check=True,
    )
    return dict(json.loads(done.stdout.strip().splitlines()[-1]))


def main(argv: list[str] | None = None) -> int:
    """Run the campaign; print and write the totals by verdict."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--cases", type=Path, default=HERE / "cases.json")
    parser.add_argument("--jobs", type=int, default=2)
    parser.add_argument("--only", help="run the cases whose id starts with this")
    parser.add_argument("--sample", type=int, help="run about this many cases, spread evenly")
    parser.add_argument("--work", type=Path, default=Path("/tmp/bubblerob_hostile"))
    parser.add_argument("--summary", type=Path, help="write every case's verdict here (JSON)")
    args = parser.parse_args(argv)
    cases = load_cases(args.cases, args.only, args.sample)
    started = time.monotonic()
    fixtures = fixtures_in(args.work)
    snippets = [c for c in cases if "python" in c]
    batches = [snippets[k :: args.jobs] for k in range(args.jobs)]
    with ThreadPoolExecutor(args.jobs) as pool:
        batched = pool.map(lambda batch: run_snippets(batch, fixtures, args.work), batches)
        results = [r for batch in batched for r in batch]
        commands = [c for c in cases if "python" not in c]
        results += list(pool.map(lambda c: run_case(c, fixtures, args.work), commands))
    totals = Counter(r["verdict"] for r in results)
    for r in results:
        if r["verdict"] != "ok":
            print(f"{r['verdict']:>15}  {r['id']}  rc={r['rc']}  {r['stderr_tail'][-200:]!r}")
    seconds = time.monotonic() - started
    print(
        f"{len(results)} cases in {seconds:.0f} s: "
        + ", ".join(f"{v} {n}" for v, n in totals.most_common())
    )
    if args.summary is not None:
        summary = {"cases": len(results), "seconds": round(seconds), "totals": dict(totals)}
        args.summary.write_text(json.dumps({**summary, "results": results}, indent=1) + "\n")
    return 0 if totals["ok"] == len(results) else 1


if __name__ == "__main__":
    sys.exit(main())
