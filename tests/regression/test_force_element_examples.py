"""The issue-12 examples in input/ against the `expected` results in their YAML (docs/input.md,
"expected"): the slider-crank with a flexible connecting rod driven by a motor torque through a
torsional damper (em energy balance, rotor speed, rod force), the pendulum with a massless rod on a
revolute joint (amplitude and largest kinetic energy against the closed form), and the
bushing-mounted rigid body on a flexible beam after a static stage (root reaction = weight, em
energy balance). With --input, only that example (the 2-rank run takes the bushing mount alone)."""

import msflex_testing as mt

args = mt.parse_arguments(__doc__)
check = mt.Checker("force-element examples")
names = [args.input.split("/")[-1].removesuffix(".yaml")] if args.input else ["slider_crank", "massless_pendulum", "bushing_mount"]
for name in names:
    source = f"{args.source_dir}/input/{name}.yaml"
    output = f"{args.work_dir}/{name}.h5"
    mt.run_msflex(args, source, output, extra=["-quiet"])
    checked, skipped = mt.check_expected(check, source, output, name)
    check.true(f"{name}: {checked} expected results checked, none skipped", checked > 0 and skipped == 0)
check.finish()
