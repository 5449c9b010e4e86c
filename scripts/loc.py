#!/usr/bin/env python3
"""Lines of code of a crate's src/ without tests: non-blank lines that are not comments, with
`#[cfg(test)]` modules (at the end of a file, as in this workspace) left out.

    scripts/loc.py firmware/src [REV]   # REV: count the files of a git revision instead
"""
import subprocess
import sys


def count(text):
    n = 0
    lines = text.split("\n")
    for i, line in enumerate(lines):
        s = line.strip()
        if s == "#[cfg(test)]" and i + 1 < len(lines) and lines[i + 1].strip().startswith("mod tests"):
            break
        if s and not s.startswith("//"):
            n += 1
    return n


def main():
    root = sys.argv[1]
    rev = sys.argv[2] if len(sys.argv) > 2 else None
    if rev:
        files = subprocess.run(["git", "ls-tree", "-r", "--name-only", rev, root],
                               capture_output=True, text=True, check=True).stdout.split()
        read = lambda f: subprocess.run(["git", "show", f"{rev}:{f}"], capture_output=True,
                                        text=True, check=True).stdout
    else:
        files = subprocess.run(["git", "ls-files", "--cached", "--others", "--exclude-standard", root],
                               capture_output=True, text=True, check=True).stdout.split()
        read = lambda f: open(f).read()
    total = 0
    # A `tests.rs` is a `#[cfg(test)] mod tests;` in a file of its own.
    for f in sorted(x for x in files if x.endswith(".rs") and not x.endswith("/tests.rs")):
        n = count(read(f))
        total += n
        print(f"{n:6} {f}")
    print(f"{total:6} total")


if __name__ == "__main__":
    main()
