"""Run Jason's own standard-library test files on Jason and on MRSS and compare.

    python -m tests.agentspeak.jason_stdlib_check --jason-src DIR --jason CLASSPATH
        [--java JAVA] [--seconds S] [--keep OUTDIR] [NAME ...]

DIR is a checkout of jason-lang/jason (3.1: its `src/test/jason/asl/stdlib/*.asl`, 46
files); CLASSPATH holds Jason's classes and a javax.json API, as for
tests/agentspeak/jason_check.py (its docstring says how to build them). Jason's own
tester reports to a test_manager agent it creates, which MRSS does not run; each file
runs instead with jason_stdlib/tester_agent.asl, a plain tester whose assertions print
`pass` or `FAIL` with their values, and a driver appended to the file that achieves its
`[test]` plans in turn (`test NAME` before each, `done` at the end). Every file runs
alone, on Jason as a one-agent MAS for `--seconds` (Jason never exits by itself) and on
MRSS through `mrss agent`; a file is `same` when both print the same lines. NAMEs pick
files (default: all). `--keep` writes each side's lines to OUTDIR/NAME.jason and
NAME.mrss.
"""

from __future__ import annotations

import argparse
import os
import re
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

HERE = Path(__file__).parent
REPO = HERE.parents[1]
TESTER = HERE / "jason_stdlib" / "tester_agent.asl"
CONFORMANCE = HERE / "conformance" / "jason"
TEST_PLAN = re.compile(r"@(\w*)\[([^\]]*)\]\s*\+!(\w+)")


def with_driver(source: str) -> str:
    """The test file with a driver that achieves its `[test]` plans in order."""
    tests = [m.group(3) for m in TEST_PLAN.finditer(source)
             if re.search(r"\btest\b", m.group(2))]
    steps = "; ".join(f'.print("test {t}"); !{t}' for t in tests) or "true"
    driver = f'\n!execute_test_plans.\n+!execute_test_plans <- {steps}; .print("done").\n'
    handlers = "".join(f'-!{t}[error(E)] <- .print("ERROR {t} ", E).\n' for t in tests)
    return source + driver + handlers


def _prepare(work: Path, asl: Path) -> None:
    shutil.copy(TESTER, work / "tester_agent.asl")
    (work / "prog.asl").write_text(with_driver(asl.read_text(encoding="utf-8")),
                                   encoding="utf-8")


def on_jason(asl: Path, java: str, classpath: str, env_classes: Path,
             seconds: float) -> list[str]:
    with tempfile.TemporaryDirectory(prefix="mrss-jason-stdlib-") as tmp:
        work = Path(tmp)
        _prepare(work, asl)
        (work / "t.mas2j").write_text("MAS t { environment: PrintEnv agents: ag prog.asl; }\n")
        try:
            done = subprocess.run(
                [java, "-cp", f"{classpath}:{env_classes}", "jason.infra.local.RunLocalMAS",
                 "t.mas2j", "--log-conf", str(CONFORMANCE / "logging.properties")],
                cwd=work, capture_output=True, text=True, timeout=seconds)
            console = done.stdout + done.stderr
        except subprocess.TimeoutExpired as stopped:
            console = "".join(s.decode() if isinstance(s, bytes) else (s or "")
                              for s in (stopped.stdout, stopped.stderr))
    return [line[5:] for line in console.splitlines() if line.startswith("[ag] ")]


def on_mrss(asl: Path, seconds: float) -> list[str]:
    with tempfile.TemporaryDirectory(prefix="mrss-jason-stdlib-") as tmp:
        work = Path(tmp)
        _prepare(work, asl)
        env = dict(os.environ)  # this checkout's mrss, whatever the folder
        env["PYTHONPATH"] = os.pathsep.join(filter(None, [str(REPO), env.get("PYTHONPATH")]))
        done = subprocess.run([sys.executable, "-m", "mrss", "agent", "prog.asl",
                               "--max-time", str(seconds)], cwd=work, capture_output=True,
                              text=True, timeout=seconds * 3 + 30, env=env)
    return done.stdout.splitlines()


def main(argv: list[str]) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--jason-src", required=True, type=Path)
    parser.add_argument("--jason", required=True, help="classpath of Jason and a JSON API")
    parser.add_argument("--java", default=shutil.which("java") or "java")
    parser.add_argument("--seconds", type=float, default=10.0)
    parser.add_argument("--keep", type=Path)
    parser.add_argument("names", nargs="*")
    args = parser.parse_args(argv)
    files = sorted((args.jason_src / "src/test/jason/asl/stdlib").glob("*.asl"))
    if args.names:
        files = [f for f in files if f.stem in args.names]
    if args.keep:
        args.keep.mkdir(parents=True, exist_ok=True)
    same = 0
    with tempfile.TemporaryDirectory(prefix="mrss-jason-env-") as env:
        subprocess.run([str(Path(args.java).with_name("javac")), "-cp", args.jason, "-d", env,
                        str(CONFORMANCE / "PrintEnv.java")], check=True)
        for asl in files:
            jason = on_jason(asl, args.java, args.jason, Path(env), args.seconds)
            mrss = on_mrss(asl, args.seconds)
            if args.keep:
                for side, lines in (("jason", jason), ("mrss", mrss)):
                    (args.keep / f"{asl.stem}.{side}").write_text(
                        "".join(f"{line}\n" for line in lines), encoding="utf-8")
            same += jason == mrss
            print(f"{'same' if jason == mrss else 'differs':8} {asl.stem}", flush=True)
    print(f"{same} of {len(files)} files print the same on Jason and MRSS")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
