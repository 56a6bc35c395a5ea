"""Bad input through the executable: for a few corpus files (tests/bad_input), serially and
under --np ranks, msflex exits with status 1 within the time limit (no rank hangs) and prints one
line 'file:line:column: error: ...' naming the offending line, without a PETSc trace-back."""

import re

import msflex_testing as mt

args = mt.parse_arguments(__doc__)
check = mt.Checker("bad input through the executable")
corpus = f"{args.source_dir}/tests/bad_input"
for name in ("section_EA_negative.yaml", "beam_unknown_section.yaml", "mechanism_no_supports.yaml", "yaml_syntax_error.yaml"):
    path = f"{corpus}/{name}"
    with open(path) as f:
        expected_line = int(re.search(r"#\s*line:\s*(\d+)", f.read()).group(1))
    for ranks in sorted({1, args.np}):
        code, stdout, stderr = mt.run_msflex(args, path, f"{args.work_dir}/unused.h5", np_ranks=ranks, expect_success=False)
        lines = [line for line in stderr.splitlines() if line.startswith("msflex:")]
        print(f"np {ranks} {name}: exit {code}: {lines[0] if lines else stderr.strip()[:200]}")
        check.less(f"np {ranks} {name}: |exit status - 1|", abs(code - 1), 0.5)
        check.less(f"np {ranks} {name}: message lines - 1", abs(len(lines) - 1), 0.5)
        located = bool(lines) and re.search(rf"{re.escape(path)}:{expected_line}:\d+: error: ", lines[0]) is not None
        check.less(f"np {ranks} {name}: message lacks file:{expected_line}:column (0 = has it)", 0.0 if located else 1.0, 0.5)
        check.less(f"np {ranks} {name}: PETSc trace-back lines", stderr.count("PETSC ERROR"), 0.5)
check.finish()
