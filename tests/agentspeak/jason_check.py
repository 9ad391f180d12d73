"""Run the conformance programs on Jason and record what it printed (conformance/jason.toml).

    python -m tests.agentspeak.jason_check --jason CLASSPATH [--java JAVA] [--seconds S]

CLASSPATH holds Jason's classes (3.3 or later needs Java 21+) and a javax/jakarta JSON
API; Jason is not on PyPI or in Debian: build it from its source (jason-lang/jason, with
its gradle build, or `javacc` on its two .jj grammars and `javac` on the rest). Each
program runs alone as `agents: NAME NAME.asl` of a one-agent MAS, with an environment
that prints each action as mrss's ConsoleHost does (conformance/jason/PrintEnv.java),
for `--seconds` (Jason never exits by itself); its `[NAME] ` lines are its output.

Per program, jason.toml says `same` (Jason printed exactly NAME.out), `differs` (Jason
printed conformance/jason/NAME.out instead), or `refused` (Jason did not run it: the
first error line is kept); with the sha256 of the NAME.out it was compared with, so a
hand edit of NAME.out shows as unchecked (tests/agentspeak/test_conformance.py). Notes
(`note = ...`) already in jason.toml are kept.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import re
import shutil
import subprocess
import sys
import tempfile
import tomllib
from pathlib import Path

HERE = Path(__file__).parent / "conformance"
MANIFEST = HERE / "jason.toml"
KEYWORDS = {"events", "agents", "environment", "infrastructure", "executionControl"}


def out_sha256(name: str) -> str:
    return hashlib.sha256((HERE / f"{name}.out").read_bytes()).hexdigest()


def run_on_jason(name: str, java: str, classpath: str, seconds: float) -> tuple[list[str], str]:
    """Jason's lines for program `name`, and its console (for the first error)."""
    agent = f"{name}_ag" if name in KEYWORDS else name  # a mas2j keyword is no name
    with tempfile.TemporaryDirectory(prefix="mrss-jason-") as tmp:
        work = Path(tmp)
        shutil.copytree(HERE, work, dirs_exist_ok=True)
        source = f"{name}_prog" if name in KEYWORDS else name  # a file name is parsed too
        shutil.copy(HERE / f"{name}.asl", work / f"{source}.asl")
        (work / "t.mas2j").write_text(
            f"MAS t {{ environment: PrintEnv agents: {agent} {source}.asl; }}\n")
        subprocess.run([str(Path(java).with_name("javac")), "-cp", classpath, "-d", tmp,
                        str(HERE / "jason" / "PrintEnv.java")], check=True)
        try:
            done = subprocess.run([java, "-cp", f"{classpath}:{tmp}",
                                   "jason.infra.local.RunLocalMAS", "t.mas2j", "--log-conf",
                                   str(HERE / "jason" / "logging.properties")], cwd=work,
                                  capture_output=True, text=True, timeout=seconds)
            console = done.stdout + done.stderr
        except subprocess.TimeoutExpired as stopped:
            console = "".join(
                s.decode() if isinstance(s, bytes) else (s or "")
                for s in (stopped.stdout, stopped.stderr))
    prefix = f"[{agent}] "
    return [line[len(prefix):] for line in console.splitlines()
            if line.startswith(prefix)], console


def main(argv: list[str]) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--jason", required=True, help="classpath of Jason and a JSON API")
    parser.add_argument("--java", default=shutil.which("java") or "java")
    parser.add_argument("--seconds", type=float, default=20.0)
    parser.add_argument("--source", default="", help="which Jason: repository and commit")
    args = parser.parse_args(argv)
    old = tomllib.loads(MANIFEST.read_text()) if MANIFEST.exists() else {}
    notes = {n: p.get("note", "") for n, p in old.get("programs", {}).items()}
    source = args.source or old.get("jason", {}).get("source", "")
    lines = ["# Which conformance outputs were checked against Jason, and what it printed.",
             "# Written by tests/agentspeak/jason_check.py (its docstring says how);",
             "# the notes by hand.",
             "[jason]", f"source = {json.dumps(source)}", ""]
    for path in sorted(HERE.glob("*.asl")):
        name = path.stem
        got, console = run_on_jason(name, args.java, args.jason, args.seconds)
        expected = (HERE / f"{name}.out").read_text(encoding="utf-8").splitlines()
        kept = HERE / "jason" / f"{name}.out"
        error = next((line for line in console.splitlines()
                      if re.search(r"error parsing|ParseException|Exception:", line)), "")
        if got == expected:
            verdict = "same"
        elif not got and error:
            verdict = "refused"
        else:
            verdict = "differs"
        if verdict == "differs":
            kept.write_text("".join(f"{line}\n" for line in got), encoding="utf-8")
        else:
            kept.unlink(missing_ok=True)
        lines += [f"[programs.{name}]", f'verdict = "{verdict}"',
                  f'out_sha256 = "{out_sha256(name)}"']
        if verdict == "refused":
            lines.append(f"jason_error = {json.dumps(error.strip()[:200])}")
        if notes.get(name):
            lines.append(f"note = {json.dumps(notes[name])}")
        lines.append("")
        print(f"{verdict:8} {name}", flush=True)
    MANIFEST.write_text("\n".join(lines), encoding="utf-8")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
