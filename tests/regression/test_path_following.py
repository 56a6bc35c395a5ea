"""Path following on the von Mises truss with a series spring (input/von_mises_truss.yaml), whose
path is known in closed form: P(w) = 2 EA y (1/L - 1/L0) with y = h - w, L = sqrt(a^2 + y^2), and the
spring's top at u = w + P/k.

 - arc length: every converged state lies on the closed-form path (|lambda P_ref - P(w)| <= 1e-8
   P_ref, |u - w - P/k| <= 1e-10), through both limit points (lambda = +-0.383837398174347, named as
   limit points, located to 1e-6) and the snap-back of u, to lambda = 1 exactly; the negative pivots
   are 0 before the first limit point, 1 between the two and 0 after;
 - load control follows the same path up to the limit point and then jumps to the far branch: the
   states before the jump lie on the path, and the jump is named;
 - with too few Newton iterations to jump, load control stops near the limit point with a message
   that names it and suggests arc length;
 - displacement control of the apex passes both limit points; displacement control of the spring's
   top, which turns back in the snap-back, jumps (and the jump is named);
 - the arc-length run's last line gives the load factor it reached and the path parameter apart,
   and its summary counts the bordered solves (two per Newton iteration that solves) as Krylov
   iterations and logs the corrector's assembly in the Assembly stage;
 - the truss without its load: nothing moves, and no step names a critical point (the jump test,
   whose path tangent is then zero, once named a jump at every step).
Also on --np ranks (the main run)."""

import numpy as np

import msflex_testing as mt

A, H, EA, K_SPRING, P_REF = 1.0, 0.5, 1.0e6, 1.0e5, 1.0e5
L0 = np.hypot(A, H)
LIMIT_W = H - np.sqrt((A * A * L0) ** (2.0 / 3.0) - A * A)  # the first limit point: L^3 = a^2 L0


def load(w):
    y = H - w
    return 2.0 * EA * y * (1.0 / np.hypot(A, y) - 1.0 / L0)


LIMIT = load(LIMIT_W) / P_REF


def deflection_at(lam, low, high):
    """The apex deflection where P(w) = lam P_ref on a monotone stretch [low, high] (bisection)."""
    for _ in range(200):
        middle = 0.5 * (low + high)
        if (load(middle) - lam * P_REF) * (load(low) - lam * P_REF) > 0:
            low = middle
        else:
            high = middle
    return 0.5 * (low + high)


def run(name, extra=()):
    """Runs the truss with the extra options; its history and the apex and top deflections."""
    path = f"{args.work_dir}/{name}.h5"
    mt.run_msflex(args, truss, path, extra=list(extra))
    history = mt.history(path)
    apex = mt.probe_history(path, "apex")
    top = mt.probe_history(path, "top")
    return history, -apex["displacement"][:, 1], -top["displacement"][:, 1]


args = mt.parse_arguments(__doc__)
check = mt.Checker("path following")
truss = f"{args.source_dir}/input/von_mises_truss.yaml"
print(f"closed form: limit load factor {LIMIT:.15f} at w = {LIMIT_W:.15f}")

# Arc length.
history, w, u = run("arc")
lam = history["load_factor"]
check.less("arc length: max |lambda P_ref - P(w)| / P_ref", np.abs(lam * P_REF - load(w)).max() / P_REF, 1e-8)
check.less("arc length: max |u - w - P / k|", np.abs(u - w - lam * P_REF / K_SPRING).max(), 1e-10)
limits = history["critical_load_factor"][history["critical_point"] == 1]
print(f"arc length: limit points at {limits}, {len(lam) - 1} steps")
check.equal("arc length: limit points found", len(limits), 2)
if len(limits) == 2:
    check.less("arc length: first limit load relative error", abs(limits[0] / LIMIT - 1), 1e-6)
    check.less("arc length: second limit load relative error", abs(limits[1] / -LIMIT - 1), 1e-6)
pivots = history["negative_pivots"]
expected = np.where((w > LIMIT_W + 1e-9) & (w < 2 * H - LIMIT_W - 1e-9), 1, 0)
far = np.abs(w - LIMIT_W) > 1e-3
far &= np.abs(w - (2 * H - LIMIT_W)) > 1e-3
check.equal("arc length: states with the wrong number of negative pivots", np.count_nonzero(pivots[far] != expected[far]), 0)
snap_back = np.any(np.diff(u) < -1e-3)
check.true("arc length: the top of the spring moves back (snap-back)", bool(snap_back))
check.less("arc length: |final load factor - 1|", abs(lam[-1] - 1.0), 1e-12)
check.less("arc length: |final w - closed form|", abs(w[-1] - deflection_at(1.0, 2 * H - LIMIT_W, 3.0)), 1e-8)

# Load control: on the path until it jumps over the limit point.
history, w, u = run("load", ["-analysis_control", "load"])
lam = history["load_factor"]
before = lam < LIMIT
check.less("load control: states before the limit point off the path", np.abs(lam[before] * P_REF - load(w[before])).max() / P_REF, 1e-8)
branch = np.array([deflection_at(x, 0.0, LIMIT_W) for x in lam[before]])
check.less("load control: max |w - w(lambda) on the rising branch|", np.abs(w[before] - branch).max(), 1e-8)
jumps = np.nonzero(history["critical_point"] == 3)[0]
print(f"load control: jump named at steps {jumps}, load factors {lam[jumps]}")
check.equal("load control: jumps named", len(jumps), 1)
if len(jumps):
    check.true("load control: the jump is the first step past the limit point", bool(lam[jumps[0]] > LIMIT > lam[jumps[0] - 1]))

# The Williams toggle under load control, steps of 4: the one step that snaps through (both its
# ends stable) is named a jump, the first step past the limit point that arc length finds (a
# deviation of 1.99 from the start's prediction: the threshold 2 missed it).
toggle = f"{args.source_dir}/tests/regression/inputs/williams_toggle.yaml"
mt.run_msflex(args, toggle, f"{args.work_dir}/toggle_arc.h5", extra=["-analysis_control", "arc_length"])
arc = mt.history(f"{args.work_dir}/toggle_arc.h5")
toggle_limit = arc["critical_load_factor"][arc["critical_point"] == 1][0]
mt.run_msflex(args, toggle, f"{args.work_dir}/toggle_load.h5")
history = mt.history(f"{args.work_dir}/toggle_load.h5")
jumps = np.nonzero(history["critical_point"] == 3)[0]
print(f"toggle: limit point {toggle_limit:.6g} (arc length); load control names jumps at load factors {history['load_factor'][jumps]}")
check.equal("toggle, load control in steps of 4: jumps named", len(jumps), 1)
if len(jumps):
    check.true("toggle: the jump is the first step past the limit point",
               bool(history["load_factor"][jumps[0]] > toggle_limit > history["load_factor"][jumps[0] - 1]))

# Load control that cannot jump: it stops at the limit point and says so.
code, _, stderr = mt.run_msflex(args, truss, f"{args.work_dir}/stop.h5",
                                extra=["-analysis_control", "load", "-analysis_max_newton_iterations", "6", "-analysis_min_step", "1e-3"],
                                expect_success=False)
message = " ".join(line for line in stderr.splitlines() if line.startswith("msflex:"))
print("load control stop message:", message[:600])
check.equal("stopped run: exit status", code, 1)
check.true("the stop message names a limit point and arc length", "limit point" in message and "arc_length" in message)

# Displacement control of the apex: through both limit points.
history, w, u = run("apex", ["-analysis_control", "displacement", "-analysis_control_node", "apex", "-analysis_control_dof", "uy",
                             "-analysis_control_value", "-1", "-analysis_end_time", "1.19"])
lam = history["load_factor"]
check.less("apex control: max |lambda P_ref - P(w)| / P_ref", np.abs(lam * P_REF - load(w)).max() / P_REF, 1e-8)
check.less("apex control: max |w - control_value t|", np.abs(w - history["time"]).max(), 1e-10)
limits = history["critical_load_factor"][history["critical_point"] == 1]
print(f"apex control: limit points at {limits}")
check.equal("apex control: limit points found", len(limits), 2)
if len(limits) == 2:
    # Steps of 0.075 in w: the cubic through the ends of the step locates the maximum to ~3e-5.
    check.less("apex control: limit loads relative error", max(abs(limits[0] / LIMIT - 1), abs(limits[1] / -LIMIT - 1)), 2e-4)

# Displacement control of the spring's top: it cannot follow the snap-back and jumps.
history, w, u = run("top", ["-analysis_control", "displacement", "-analysis_control_node", "top", "-analysis_control_dof", "uy",
                            "-analysis_control_value", "-1", "-analysis_initial_step", "0.05"])
jumps = np.nonzero(history["critical_point"] == 3)[0]
print(f"top control: jump named at u = {u[jumps]}")
check.true(f"top control: at least 1 jump named ({len(jumps)})", len(jumps) >= 1)

# The arc-length run's report: load factor and path parameter, Krylov iterations, Assembly stage.
import re  # noqa: E402
_, stdout, _ = mt.run_msflex(args, truss, f"{args.work_dir}/report.h5")
done = re.search(r"completed (\d+) steps to load factor ([0-9.eE+-]+) \(path parameter t = ([0-9.eE+-]+)\)", stdout)
newton = re.search(r"Newton iterations\s+(\d+) in accepted steps, (\d+) in all attempts", stdout)
krylov = re.search(r"Krylov iterations\s+(\d+) in all attempts", stdout)
assembly = re.search(r"Assembly ([0-9.eE+-]+) s", stdout)
print(f"arc-length report: {done.group(0) if done else None}; {newton.group(0) if newton else None}; {krylov.group(0) if krylov else None}; "
      f"{assembly.group(0) if assembly else None}")
check.true("arc length: the last line gives the load factor and the path parameter", done is not None)
if done:
    check.less("arc length: final load factor - 1", abs(float(done.group(2)) - 1.0), 1e-12)
    check.true("arc length: the path parameter differs from the load factor", float(done.group(3)) > 1.5)
if newton and krylov:
    attempts, solves = int(newton.group(2)), int(krylov.group(1))
    check.true(f"arc length: Krylov iterations {solves} between the Newton iterations {attempts} and twice them", attempts <= solves <= 2 * attempts)
check.true("arc length: the corrector's assembly is logged in the Assembly stage", assembly is not None and float(assembly.group(1)) > 0)

# Force elements and reaction probes in every row of a path-followed run, and the landing row's
# path parameter (tests/regression/inputs/arc_length_springs.yaml).
for control in ("arc_length", "displacement"):
    extra = ["-analysis_control", control] + (["-analysis_control_node", "B", "-analysis_control_dof", "uy", "-analysis_control_value", "0.01"]
                                              if control == "displacement" else [])
    mt.run_msflex(args, f"{args.source_dir}/tests/regression/inputs/arc_length_springs.yaml", f"{args.work_dir}/springs_{control}.h5", extra=["-quiet"] + extra)
    h = mt.history(f"{args.work_dir}/springs_{control}.h5")
    rows = slice(1, None)
    check.less(f"springs, {control}: max |spr.force + 100 j1.rx| over the rows", np.abs(h["spr.force"][rows] + 100.0 * h["j1.rx"][rows]).max(), 1e-9)
    check.less(f"springs, {control}: max |sd.tension - 500 (sd.length - 1)|", np.abs(h["sd.tension"][rows] - 500.0 * (h["sd.length"][rows] - 1.0)).max(), 1e-9)
    check.true(f"springs, {control}: every row after the first has a spring force", bool(np.all(np.abs(h["spr.force"][rows]) > 1e-3)))
    check.less(f"springs, {control}: max |ra.force_y + sd.tension| / sd.tension (the anchor holds the spring)",
               np.abs(h["ra.force_y"][rows] + h["sd.tension"][rows]).max() / np.abs(h["sd.tension"][rows]).max(), 1e-3)
h = mt.history(f"{args.work_dir}/springs_arc_length.h5")
check.less("springs, arc length: |t - load factor| of the landing row (t ~ load factor on this path)", abs(h["time"][-1] - h["load_factor"][-1]), 1e-3)

# Displacement control of a DOF the load pattern does not move (the apex's ux, by symmetry): a
# shorter step cannot help, so the run stops after the first attempt instead of halving down to
# min_step (16 rejected attempts before).
code, stdout, stderr = mt.run_msflex(args, truss, f"{args.work_dir}/still.h5",
                                     extra=["-analysis_control", "displacement", "-analysis_control_node", "apex", "-analysis_control_dof", "ux",
                                            "-analysis_control_value", "0.1"], expect_success=False)
message = " ".join(line for line in stderr.splitlines() if line.startswith("msflex:"))
print("unmoved controlled DOF:", message[:400])
check.equal("unmoved controlled DOF: exit status", code, 1)
check.equal("unmoved controlled DOF: rejected attempts", stdout.count("rejected:"), 1)
check.true("unmoved controlled DOF: the message says a shorter step cannot help", "a shorter step cannot help" in message and "arc length" in message)

# Without load: the path stays at the reference state and names no critical point.
import yaml  # noqa: E402
with open(truss) as f:
    unloaded = yaml.safe_load(f)
unloaded.pop("loads")
unloaded.pop("expected", None)
unloaded_file = f"{args.work_dir}/truss_unloaded.yaml"
with open(unloaded_file, "w") as f:
    yaml.safe_dump(unloaded, f)
path = f"{args.work_dir}/truss_unloaded.h5"
mt.run_msflex(args, unloaded_file, path, extra=["-analysis_control", "load"])
history = mt.history(path)
named = int(np.count_nonzero(history["critical_point"]))
print(f"no load: {len(history['time']) - 1} steps, critical points named {named}, largest strain energy {np.max(history['strain_energy']):.3e}")
check.true("no load: steps taken", len(history["time"]) > 2)
check.equal("no load: critical points named", named, 0)
check.less("no load: largest strain energy (J)", float(np.max(np.abs(history["strain_energy"]))), 1e-20)
check.finish()
