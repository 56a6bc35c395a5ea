#!/usr/bin/env python3
"""Every C++ source of src/ and tests/ is formatted with the repository's .clang-format.

Usage: check_format.py SOURCE_DIR CLANG_FORMAT   (exit status 1 and the files that differ when any;
scripts/format rewrites them)."""
import pathlib
import subprocess
import sys


def main():
    root = pathlib.Path(sys.argv[1])
    clang_format = sys.argv[2] if len(sys.argv) > 2 else "clang-format"
    files = sorted(p for folder in ("src", "tests") for p in (root / folder).rglob("*") if p.suffix in (".cpp", ".hpp"))
    differing = []
    for path in files:
        formatted = subprocess.run([clang_format, f"--style=file:{root / '.clang-format'}", str(path)], capture_output=True, text=True, check=True).stdout
        if formatted != path.read_text(encoding="utf-8"):
            differing.append(path.relative_to(root))
    for path in differing:
        print(f"{path}: not formatted (run scripts/format)")
    print(f"format: {len(files)} files, {len(differing)} not formatted")
    return 1 if differing else 0


if __name__ == "__main__":
    sys.exit(main())
