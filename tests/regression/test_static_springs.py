"""Statics of bodies that only springs hold along a released direction: the reader's static
mechanism check counts a spring on a joint coordinate, and a spring between two nodes as far as it
restrains their relative motion (a damper alone holds nothing: tests/bad_input/
mechanism_coordinate_damper_only.yaml and the other mechanism_*.yaml cases are still refused).

1. tests/regression/inputs/static_torsion_spring.yaml: a rigid body of mass m = 3 kg with its centre
   of mass at L = 0.5 m from its node along x, on a revolute joint to the ground about z, with a
   torsion spring k = 20 N m/rad on the joint's rotation theta (free at theta = 0), under gravity
   g = 9.81 m/s^2 along -y scaled by the load factor t (the default ramp of statics). Turned by
   theta, the centre of mass is at L (cos theta, sin theta), so the weight's moment about z is
   -m g t L cos(theta) and the spring's is -k theta; equilibrium:

       k theta + m g L t cos(theta) = 0,   i.e.  20 theta + 14.715 t cos(theta) = 0,

   one root for every t (the left side grows with theta), theta = -0.6051099178 at t = 1.
2. tests/regression/inputs/static_bushing_hinge.yaml: the same body held against the hinge's rotation
   by a bushing to a fixed anchor stiff only about z (k = 20 N m/rad). Its rotational deflection is
   eta = 2 tan(theta/2) and its energy k eta^2 / 2 (docs/force_elements.md), so

       2 k tan(theta/2) / cos^2(theta/2) + m g L t cos(theta) = 0.

3. tests/regression/inputs/static_slide_spring.yaml: a cart on a prismatic joint along x, held by a
   spring-damper k = 100 N/m from a fixed anchor on the slide's line, pushed along it by F t with
   F = 3 N: the spring's length changes by the slide's coordinate x, so x = F t / k.

4. tests/regression/inputs/static_driven_pendulum.yaml: the body of 1 on a hinge whose rotation a
   drive prescribes, theta = 0.5 t: a drive holds its coordinate, so the model (no unknowns at all)
   is no mechanism; the hinge's reaction is F_y = m g t and M_z = m g t L cos(theta) (the drive's
   moment). A modes analysis of it is one line before any file is made: it has no unknowns, hence
   no modes.

Each is compared with its closed form at every converged step to 1e-8 (Newton stops at a relative
residual of 1e-10). Before the check counted springs, msflex refused all three as mechanisms; it
refused the driven one too, and once let through it crashed in LAPACK (a solve of size 0)."""

import numpy as np

import msflex_testing as mt

args = mt.parse_arguments(__doc__)
check = mt.Checker("static springs")
k, m, g, L = 20.0, 3.0, 9.81, 0.5


def root(f, df, x):
    """Newton's method on a scalar equation from x, to round-off."""
    for _ in range(100):
        step = f(x) / df(x)
        x -= step
        if abs(step) < 1e-15:
            break
    return x


def torsion_angle(t):
    return root(lambda q: k * q + m * g * L * t * np.cos(q), lambda q: k - m * g * L * t * np.sin(q), 0.0)


def bushing_angle(t):
    # d/dq [2 tan(q/2) / cos^2(q/2)] = (1 + 3 tan^2(q/2)) / cos^2(q/2)
    return root(lambda q: 2 * k * np.tan(q / 2) / np.cos(q / 2) ** 2 + m * g * L * t * np.cos(q),
                lambda q: k * (1 + 3 * np.tan(q / 2) ** 2) / np.cos(q / 2) ** 2 - m * g * L * t * np.sin(q), 0.0)


def run(name):
    """The history of tests/regression/inputs/<name>.yaml, or None when msflex refused it."""
    output = f"{args.work_dir}/{name}.h5"
    status, stdout, stderr = mt.run_msflex(args, f"{args.source_dir}/tests/regression/inputs/{name}.yaml", output, extra=["-quiet"],
                                           expect_success=False)
    check.equal(f"{name}: exit status", status, 0)
    if status != 0:
        print(stdout + stderr)
        return None
    h = mt.history(output)
    check.less(f"{name}: |final load factor - 1|", abs(h["time"][-1] - 1.0), 1e-12)
    return h


theta_1 = torsion_angle(1.0)
check.less("closed form at t = 1: |theta + 0.6051099178|", abs(theta_1 + 0.6051099178), 1e-10)
check.less("closed form at t = 1: |20 theta + 14.715 cos(theta)|", abs(20 * theta_1 + 14.715 * np.cos(theta_1)), 1e-12)

h = run("static_torsion_spring")
if h is not None:
    exact = np.array([torsion_angle(t) for t in h["time"]])
    check.less("torsion spring: max |theta - closed form| over the steps", np.abs(h["hinge.rx"] - exact).max(), 1e-8)
    check.less("torsion spring: |theta(1) - closed form|", abs(h["hinge.rx"][-1] - theta_1), 1e-8)
    check.less("torsion spring: max |spring moment + k theta|", np.abs(h["tor.force"] + k * h["hinge.rx"]).max(), 1e-10)
    print(f"torsion spring: theta(1) = {h['hinge.rx'][-1]:.10f} rad, closed form {theta_1:.10f} rad")

h = run("static_bushing_hinge")
if h is not None:
    exact = np.array([bushing_angle(t) for t in h["time"]])
    check.less("bushing: max |theta - closed form| over the steps", np.abs(h["hinge.rx"] - exact).max(), 1e-8)
    print(f"bushing: theta(1) = {h['hinge.rx'][-1]:.10f} rad, closed form {exact[-1]:.10f} rad")

h = run("static_slide_spring")
if h is not None:
    check.less("spring-damper: max |x - F t / k|", np.abs(h["slide.tx"] - 3.0 * h["time"] / 100.0).max(), 1e-8)
    check.less("spring-damper: max |tension - F t|", np.abs(h["strut.tension"] - 3.0 * h["time"]).max(), 1e-8)

h = run("static_driven_pendulum")
if h is not None:
    t, theta = h["time"], 0.5 * h["time"]
    check.less("driven hinge: max |theta - 0.5 t|", np.abs(h["hinge.rx"] - theta).max(), 1e-12)
    check.less("driven hinge: max |F_y - m g t|", np.abs(h["hinge.force_y"] - m * g * t).max(), 1e-8)
    check.less("driven hinge: max ||M_z| - m g t L cos(theta)|", np.abs(np.abs(h["hinge.moment_z"]) - m * g * t * L * np.cos(theta)).max(), 1e-8)
import os  # noqa: E402
modes_file = f"{args.work_dir}/driven_modes.h5"
if os.path.exists(modes_file):
    os.remove(modes_file)
code, _, stderr = mt.run_msflex(args, f"{args.source_dir}/tests/regression/inputs/static_driven_pendulum.yaml", modes_file,
                                extra=["-quiet", "-analysis_type", "modes"], expect_success=False)
check.true("driven hinge, modes: no result file created", not os.path.exists(modes_file))
lines = [line for line in stderr.splitlines() if line.startswith("msflex:")]
check.equal("driven hinge, modes: exit status", code, 1)
check.true("driven hinge, modes: one line saying it has no unknowns", len(lines) == 1 and "has no unknowns" in lines[0] and "PETSC ERROR" not in stderr)
check.finish()
