"""Loads and actuators of a dynamic analysis without a function grow as f(t) = t (docs/input.md,
functions), and the run says so in one warning line on standard error naming the first with its
file and line: gravity on the spring slider (tests/regression/inputs/spring_slider.yaml), then two
ramped loads (the count), none with a constant function, and none in statics (where the ramp is
the load factor)."""

import re

import msflex_testing as mt

args = mt.parse_arguments(__doc__)
check = mt.Checker("dynamic load ramp")
with open(f"{args.source_dir}/tests/regression/inputs/spring_slider.yaml") as f:
    base = f.read().replace("end_time: 2.0", "end_time: 0.1")
WARNING = "msflex: warning: "


def run(name, extra_yaml, options=()):
    path = f"{args.work_dir}/{name}.yaml"
    with open(path, "w") as f:
        f.write(base + extra_yaml)
    _, _, stderr = mt.run_msflex(args, path, f"{args.work_dir}/{name}.h5", extra=["-quiet"] + list(options))
    return [line for line in stderr.splitlines() if line.startswith(WARNING) and "f(t) = t" in line]


warnings = run("gravity", "loads:\n  - {gravity: [-9.81, 0, 0]}\n")
print(warnings)
check.equal("gravity without a function: warning lines", len(warnings), 1)
check.true("the warning names gravity, its file and line", bool(warnings) and re.search(r"gravity \(.*gravity\.yaml:\d+\) has no function", warnings[0]) is not None)

warnings = run("two", "loads:\n  - {gravity: [-9.81, 0, 0]}\n  - {nodes: mass, force: [1, 0, 0]}\n")
print(warnings)
check.equal("two ramped loads: warning lines", len(warnings), 1)
check.true("the warning counts the second", bool(warnings) and "and 1 more loads or actuators without a function" in warnings[0])

warnings = run("constant", "functions:\n  - {name: one, type: constant, value: 1}\nloads:\n  - {gravity: [-9.81, 0, 0], function: one}\n")
check.equal("gravity with a constant function: warning lines", len(warnings), 0)

warnings = run("static", "loads:\n  - {gravity: [-9.81, 0, 0]}\n", ["-analysis_type", "static"])
check.equal("statics (the ramp is the load factor): warning lines", len(warnings), 0)
check.finish()
