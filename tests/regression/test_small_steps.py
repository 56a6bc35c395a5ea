"""Newton at the rounding noise of the inertia terms: a flywheel at rest at a joint angle of 10 rad
(tests/regression/inputs/flywheel_at_rest.yaml) spun up by a constant torque, with steps of 1e-4 s
and 1e-5 s, and an offset pendulum released from rest at 2.5 rad with steps of 1e-4 s, with every
integrator. At rest (and at a pendulum's turning point) the momenta set no round-off floor; the
residual's noise is about eps J / (beta dt^2) (the inertia coefficient times eps-sized rotation
errors), 1.5e-9 to 4.5e-9 N m for the flywheel at 1e-4 s against a needed rtol 1e-10 times 10 N m,
and halving the step raises it like 1/dt^2: every step was rejected and halved until min_step.
Now a residual below the assembler's stagnation level that an iteration no longer halves ends
Newton. Checked: every run completes without a rejected step, the flywheel's angle is
10 + T t^2 / (2 J) to 1e-9 rad, and the energy-momentum scheme keeps the pendulum's energy to
1e-9 of it.

The first history row's joint reaction (it was 0 with every integrator): released from rest at
theta_0 the pendulum (mass m, centre of mass at c = R(theta_0) (0, -0.5, 0) from the pivot,
J_zz = 0.08 about it) has alpha = (c x m g)_z / (J_zz + m |c|^2) and a_c = alpha e_z x c, so the
hinge exerts F = m (a_c - g) on it: (12.7505, 19.9051) N at theta_0 = 2.5, within 1e-9 of m g.

A dynamic run that creates energy warns on standard error (also with -quiet), naming the growth in
J and relative to the initial total energy: a beam spinning freely at 100 rad/s
(tests/regression/inputs/spinning_beam.yaml) with genalpha at its default rho_inf (its energy
balance grows to about 11 times the initial energy) and two free bodies on a revolute joint
(tests/regression/inputs/free_two_body_chain.yaml) with newmark (the slave's undamped recursion:
docs/joints.md; about 280 times) give one warning line each; with em, energy and momenta kept,
none."""

import re

import numpy as np
import yaml

import msflex_testing as mt

args = mt.parse_arguments(__doc__)
check = mt.Checker("small steps at rest")
flywheel = f"{args.source_dir}/tests/regression/inputs/flywheel_at_rest.yaml"
TORQUE, J_ZZ = 5.0, 0.08


def completes(label, source, output, options):
    """Runs msflex; checks that it completes without a rejected step; whether it completed."""
    code, stdout, _ = mt.run_msflex(args, source, output, extra=options, expect_success=False)
    rejected = re.search(r"(\d+) rejected", stdout)
    check.equal(f"{label}: exit status", code, 0)
    check.equal(f"{label}: rejected steps", int(rejected.group(1)) if rejected else -1, 0)
    return code == 0


for integrator in ("newmark", "genalpha", "mc", "em"):
    for dt in (1e-4, 1e-5):
        output = f"{args.work_dir}/flywheel_{integrator}_{dt:g}.h5"
        label = f"flywheel {integrator} dt {dt:g}"
        options = ["-analysis_integrator", integrator, "-analysis_initial_step", str(dt), "-analysis_max_step", str(dt), "-analysis_end_time", "0.002"]
        if completes(label, flywheel, output, options):
            h = mt.history(output)
            t, angle = h["time"], h["hinge.rz"] if "hinge.rz" in h else h["hinge.rx"]
            check.less(f"{label}: |angle - closed form| (rad)", float(np.max(np.abs(angle - (10.0 + TORQUE * t * t / (2 * J_ZZ))))), 1e-9)

# The pendulum: the flywheel's disc offset by 0.5 m under gravity, released from rest at 2.5 rad.
with open(flywheel) as f:
    model = yaml.safe_load(f)
model.pop("force_elements")
model["rigid_bodies"][0]["offset"] = [0.0, -0.5, 0.0]
model["loads"] = [{"gravity": [0.0, -9.81, 0.0], "function": "one"}]
model["initial_conditions"][0]["value"] = 2.5
pendulum = f"{args.work_dir}/pendulum_at_rest.yaml"
with open(pendulum, "w") as f:
    yaml.safe_dump(model, f)
for integrator in ("newmark", "genalpha", "mc", "em"):
    output = f"{args.work_dir}/pendulum_{integrator}.h5"
    label = f"pendulum {integrator} dt 1e-4"
    completed = completes(label, pendulum, output, ["-analysis_integrator", integrator, "-analysis_end_time", "0.05"])
    if completed:
        h = mt.history(output)
        m, theta0, g = 3.0, 2.5, np.array([0.0, -9.81, 0.0])
        c = 0.5 * np.array([np.sin(theta0), -np.cos(theta0), 0.0])
        alpha = np.cross(c, m * g)[2] / (0.08 + m * c @ c)
        expected = m * (alpha * np.cross([0.0, 0.0, 1.0], c) - g)
        got = np.array([h["hinge.force_x"][0], h["hinge.force_y"][0], h["hinge.force_z"][0]])
        print(f"{label}: reaction at t = 0 {got}, closed form {expected}")
        check.less(f"{label}: |reaction at t = 0 - closed form| / m g", float(np.max(np.abs(got - expected))) / (m * 9.81), 1e-9)
    if completed and integrator == "em":
        h = mt.history(output)
        drift = float(np.max(np.abs(h["energy_balance"] - h["energy_balance"][0])) / np.max(np.abs(h["total_energy"])))
        check.less(f"{label}: energy drift relative to the energy", drift, 1e-9)
runs = (("spinning beam", "spinning_beam", "genalpha", True), ("free chain", "free_two_body_chain", "newmark", True),
        ("free chain", "free_two_body_chain", "em", False))
for label, name, integrator, warned in runs:
    output = f"{args.work_dir}/{name}_{integrator}.h5"
    code, _, stderr = mt.run_msflex(args, f"{args.source_dir}/tests/regression/inputs/{name}.yaml", output, extra=["-quiet", "-analysis_integrator", integrator])
    warnings = [line for line in stderr.splitlines() if line.startswith("msflex: warning: the energy balance grew")]
    print(f"{label} {integrator}: {warnings}")
    check.equal(f"{label} {integrator}: energy-growth warnings", len(warnings), 1 if warned else 0)
    h = mt.history(output)
    growth = float(np.max(h["energy_balance"] - h["energy_balance"][0]))
    if warned:
        initial = float(h["total_energy"][0])
        check.true(f"{label} {integrator}: the energy balance grew by {growth / initial:.3g} of the initial energy (above 1)", growth > initial)
        stated = re.search(r"grew by ([0-9.e+-]+) J, ([0-9.e+-]+) times the initial total energy", warnings[0] if warnings else "")
        check.true(f"{label} {integrator}: the warning states the growth in J and relative to the initial energy", stated is not None)
        if stated:
            check.less(f"{label} {integrator}: |stated growth / growth - 1|", abs(float(stated.group(1)) / growth - 1.0), 1e-2)
    else:
        check.less(f"{label} {integrator}: energy balance growth relative to the energy", growth / np.max(np.abs(h["total_energy"])), 1e-9)
check.finish()
