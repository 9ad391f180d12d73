"""A file another process polls for (a simulator's address, a component's URL) is written
whole: a reader sees the old text or the new one, never an empty or half-written file
(a fleet simulator's address file was once read empty by a reader that found it just
created)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

from mrss.textfile import write_whole

READER = r"""
import sys
from pathlib import Path
path, done = Path(sys.argv[1]), Path(sys.argv[2])
seen, bad = 0, set()
while not done.exists():
    try:
        text = path.read_text(encoding="utf-8")
    except FileNotFoundError:
        continue
    seen += 1
    if text not in ("a" * 100000 + "\n", "b" * 100000 + "\n"):
        bad.add(len(text))
print(seen, sorted(bad))
"""


def test_a_polling_reader_never_sees_a_partial_file(tmp_path: Path) -> None:
    path, done = tmp_path / "uav1.mavlink", tmp_path / "done"
    write_whole(path, "a" * 100000 + "\n")
    reader = subprocess.Popen([sys.executable, "-c", READER, str(path), str(done)],
                              stdout=subprocess.PIPE, text=True)
    try:
        for n in range(400):
            write_whole(path, ("a" if n % 2 else "b") * 100000 + "\n")
    finally:
        done.touch()
        out, _ = reader.communicate(timeout=60)
    seen, bad = out.split(" ", 1)
    assert int(seen) > 0
    assert bad.strip() == "[]", f"reader saw partial files of these lengths: {bad}"
    # Nothing left beside it: the partial files were all renamed over the target.
    assert sorted(p.name for p in tmp_path.iterdir()) == ["done", "uav1.mavlink"]


def test_a_failed_write_leaves_the_old_text_and_no_partial_file(tmp_path: Path) -> None:
    path = tmp_path / "worldmodel.url"
    write_whole(path, "http://127.0.0.1:1/\n")
    try:
        write_whole(path, "\udcff")  # a lone surrogate cannot be encoded as UTF-8
    except UnicodeEncodeError:
        pass
    else:
        raise AssertionError("an unencodable text was written")
    assert path.read_text(encoding="utf-8") == "http://127.0.0.1:1/\n"
    assert [p.name for p in tmp_path.iterdir()] == ["worldmodel.url"]
