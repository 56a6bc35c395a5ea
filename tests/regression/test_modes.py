"""Natural frequencies and mode shapes (analysis type modes) against Euler-Bernoulli closed forms,
and the eigenvalues of every eigenanalysis on 1 and --np ranks:
 - cantilever (tests/regression/inputs/cantilever_modes.yaml, 48 quadratic elements): the 6 lowest
   frequencies of both bending planes to 1e-4 (shear stiffness 5e9: Euler-Bernoulli to 5e-5); the first mode shape (a frame) against
   cosh - cos - s (sinh - sin) to 1e-3 of the tip deflection;
 - free-free beam (free_free_modes.yaml): six rigid modes (|lambda| below the round-off level,
   flagged rigid_mode), then the 6 lowest bending frequencies to 1e-4;
 - a beam hinged by a revolute joint (input/hinged_beam_modes.yaml): one rigid mode at zero (|lambda|
   <= 1e-6 of the first elastic one), pinned-free bending in the hinge's plane and clamped-free
   bending out of it to 1e-4;
 - the hinged beam beside a wheel free to turn on a revolute joint (a motion with no stiffness at
   all, K singular to the last bit): two rigid modes, then the same frequencies; a free rigid body
   (six rigid modes) and one on a spherical joint (three), K = 0;
 - a pinned-pinned beam preloaded by a tension T and by a compression of half its Euler load
   (tension_modes.yaml): omega^2 = [(n pi/L)^4 EI + (n pi/L)^2 T] / rhoA to 1e-4 (5 lowest);
 - with --np > 1, every one of these and the two buckling analyses of test_stability give the same
   eigenvalues on 1 and --np ranks to 1e-8 relative (rigid modes: must be rigid on both), or, where
   the pencil's round-off is larger, to 4 times the spread between two factorisations on one rank
   (MUMPS's default ordering and AMD, -st_mat_mumps_icntl_7 0): the rank count may change the
   eigenvalues no more than a different pivot order does. The half-Euler compressed beam, whose
   lowest eigenvalue is halved, is such a case: 1 and 2 ranks differ by about 1.7e-8 there, two
   orderings on one rank by about 2e-8 (the eigensolver's tolerance, 1e-12, changes nothing);
 - -eps_nev gives the number of modes written (3 and 20: they were 6 and 12), no more modes than
   unknowns are computed and the run says so, and -st_type shift on a free beam (K singular) is
   one line, exit 1;
 - a clamped 1 mm steel wire 2 m long (slender_wire.yaml, planar): its first bending eigenvalue
   (1.875104/L)^4 EI/rhoA to 1e-4, and no mode flagged rigid (the level of a mode's round-off is its
   own, eps max|K_ii| |phi|^2: one level for all modes, 1e3 eps max K_ii/M_ii, flagged the first
   two, which the wire's tiny rotary inertia put below it); its base is fixed by two supports;
 - the hinged beam refined to 8000 elements: its first bending mode is not flagged rigid (the rigid
   level is 3 times a mode's round-off estimate: rigid modes lie at 0.32 of it or below, this beam's
   first bending mode between 3 and 30 times it) and is within 5e-3 of the clamped-free closed form."""

import math

import h5py
import numpy as np

import msflex_testing as mt

CANTILEVER = [1.875104068711961, 4.694091132974175, 7.854757438237613, 10.99554073487547, 14.13716549125746]
FREE_FREE = [4.730040744862704, 7.853204624095838, 10.99560783800167, 14.13716549125746, 17.27875965739948]
PINNED_FREE = [3.926602312047919, 7.068582745628732, 10.21017612281303, 13.35176877775409]
L, RHO_A, EI2, EI3 = 2.0, 1.0, 1.0e4, 4.0e4


def bending(betas, EI):
    return [b * b * math.sqrt(EI / (RHO_A * L**4)) for b in betas]


def run(name, input_file, extra=(), ranks=None):
    path = f"{args.work_dir}/{name}{'' if ranks in (None, 1) else f'_np{ranks}'}.h5"
    mt.run_msflex(args, input_file, path, extra=list(extra), np_ranks=ranks)
    return path


def compare(label, omega, expected, tolerance, count=6):
    """The `count` lowest frequencies against the closed forms."""
    omega = omega[:count]
    expected = np.sort(expected)[: len(omega)]
    error = np.abs(omega / expected - 1)
    print(f"{label}: omega {np.array2string(omega, precision=6)}\n{' ' * len(label)}  closed form {np.array2string(expected, precision=6)}")
    check.less(f"{label}: max relative error of {len(omega)} frequencies", error.max(), tolerance)


args = mt.parse_arguments(__doc__)
check = mt.Checker("modes")
inputs = f"{args.source_dir}/tests/regression/inputs"
runs = []  # (name, input, extra options) of every eigenanalysis, for the rank comparison

# Cantilever.
path = run("cantilever", f"{inputs}/cantilever_modes.yaml", ranks=1)
runs.append(("cantilever", f"{inputs}/cantilever_modes.yaml", ()))
history = mt.history(path)
compare("cantilever", history["angular_frequency"], bending(CANTILEVER, EI2) + bending(CANTILEVER, EI3), 1e-4)
with h5py.File(path, "r") as f:
    check.equal("cantilever: frames (equilibrium + 8 modes)", mt.frame_count(f), 9)
    kind = f.attrs["analysis_type"]
    check.true(f"cantilever: the file's analysis_type is 'modes' ({kind!r}; it read 'static')", (kind.decode() if isinstance(kind, bytes) else str(kind)) == "modes")
    frame = mt.frame(f, 1)
    check.equal("cantilever: the first mode's frame is step 1", frame["step"], 1)
    shape = frame["displacement"]
    position = frame["position"] - shape
    x = position[:, 0] / L
beta = CANTILEVER[0]
s = (math.cosh(beta) + math.cos(beta)) / (math.sinh(beta) + math.sin(beta))
reference = np.cosh(beta * x) - np.cos(beta * x) - s * (np.sinh(beta * x) - np.sin(beta * x))
deflection = shape[:, 2]  # mode 1 bends about the weak axis e2: deflection along e3
deflection = deflection / deflection[np.argmax(np.abs(deflection))] * reference[np.argmax(np.abs(deflection))]
check.less("cantilever: first mode shape error / tip deflection", np.abs(deflection - reference).max() / np.abs(reference).max(), 1e-3)

# Free-free beam.
path = run("free_free", f"{inputs}/free_free_modes.yaml", ranks=1)
runs.append(("free_free", f"{inputs}/free_free_modes.yaml", ()))
history = mt.history(path)
rigid = history["rigid_mode"] == 1
print(f"free-free: eigenvalues of the rigid modes {history['eigenvalue'][rigid]}")
check.equal("free-free: rigid modes", np.count_nonzero(rigid), 6)
check.true("free-free: the rigid modes come first", bool(np.all(rigid[:6])))
compare("free-free", history["angular_frequency"][~rigid], bending(FREE_FREE, EI2) + bending(FREE_FREE, EI3), 1e-4)

# Hinged beam: a mechanism with one rigid mode.
path = run("pinned_free", f"{args.source_dir}/input/hinged_beam_modes.yaml", ranks=1)
runs.append(("pinned_free", f"{args.source_dir}/input/hinged_beam_modes.yaml", ()))
history = mt.history(path)
rigid = history["rigid_mode"] == 1
values = history["eigenvalue"]
print(f"pinned-free: rigid mode eigenvalue {values[rigid]}, first elastic {values[~rigid][0]:.6f}")
check.equal("pinned-free: rigid modes", np.count_nonzero(rigid), 1)
check.less("pinned-free: |rigid eigenvalue| / first elastic eigenvalue", np.abs(values[0]) / values[1], 1e-6)
compare("pinned-free", history["angular_frequency"][~rigid], bending(PINNED_FREE, EI3) + bending(CANTILEVER, EI2), 1e-4)

# The hinged beam beside a wheel on a revolute joint without a spring: the wheel's turning has no
# stiffness at all, K is singular to the last bit and its factorisation at shift 0 fails. The
# fallback shift was -1e-2 of the smallest K_ii/M_ii (-2.9e11, set by EA): the solve did not converge
# there ("found 0 of the 8 modes"), and with 8 elements the first bending mode was called rigid. The
# shift is now at K's round-off level below zero: two rigid modes, then the pinned-free beam's
# frequencies, unchanged by the wheel.
with open(f"{args.source_dir}/input/hinged_beam_modes.yaml") as f:
    wheel = f.read().split("expected:")[0].replace("  tip: [2, 0, 0]\n", "  tip: [2, 0, 0]\n  wheel: [0, 1, 0]\n")
wheel = wheel.replace("joints:\n", "rigid_bodies:\n  - {node: wheel, mass: 1.0, inertia: [1, 1, 1]}\njoints:\n  - {name: axle, type: revolute, master: ground, slave: wheel, axis: [0, 0, 1]}\n")
assert "wheel: [0, 1, 0]" in wheel and "axle" in wheel
with open(f"{args.work_dir}/hinged_wheel.yaml", "w") as f:
    f.write(wheel)
runs.append(("hinged_wheel", f"{args.work_dir}/hinged_wheel.yaml", ()))
h = mt.history(run("hinged_wheel", f"{args.work_dir}/hinged_wheel.yaml", ranks=1))
rigid = h["rigid_mode"] == 1
check.true(f"hinged beam and a free wheel: the first two modes are rigid ({h['rigid_mode'].tolist()})", h["rigid_mode"].tolist() == [1, 1] + [0] * (len(rigid) - 2))
compare("hinged beam and a free wheel", h["angular_frequency"][~rigid], bending(PINNED_FREE, EI3) + bending(CANTILEVER, EI2), 1e-4)
# Models of rigid bodies with no stiffness at all (K = 0): a free body has six rigid modes, a body
# on a spherical joint three ("no eigenvalue of the model could be estimated" before), each with a
# backward error measured at the shift's scale (SLEPc's is 0/0 or O(1) at lambda = 0).
for name, text, modes in (("free_body", "nodes: {b: [1, 0, 0]}\n", 6),
                          ("ball_body", "nodes: {b: [1, 0, 0]}\njoints: [{name: ball, type: spherical, master: ground, slave: b}]\n", 3)):
    with open(f"{args.work_dir}/{name}.yaml", "w") as f:
        f.write(text + f"rigid_bodies: [{{node: b, mass: 2.0, inertia: [0.5, 0.6, 0.7], offset: [0, 0.2, 0]}}]\nanalysis: {{type: modes, eigenvalues: {modes}}}\n")
    h = mt.history(run(name, f"{args.work_dir}/{name}.yaml", ranks=1))
    check.true(f"{name}: {modes} modes, every one rigid ({h['rigid_mode'].tolist()})", h["rigid_mode"].tolist() == [1] * modes)
    check.less(f"{name}: largest backward error", float(np.max(h["backward_error"])), 1e-12)

# Two separate spring-mass slides, omega^2 = 1e-8 and 1e6: both elastic. 1e-6 of the largest
# eigenvalue found took the slow one for rigid (frequency 0, rigid_mode 1).
with open(f"{args.work_dir}/slow_and_fast.yaml", "w") as f:
    f.write("nodes: {a: [1, 0, 0], b: [2, 0, 0]}\n"
            "rigid_bodies: [{node: a, mass: 1.0e4, inertia: [1, 1, 1]}, {node: b, mass: 1.0, inertia: [1, 1, 1]}]\n"
            "joints: [{name: ja, type: prismatic, master: ground, slave: a, axis: [1, 0, 0]}, {name: jb, type: prismatic, master: ground, slave: b, axis: [1, 0, 0]}]\n"
            "force_elements: [{name: ka, type: coordinate, joint: ja, coordinate: tx, stiffness: 1.0e-4}, {name: kb, type: coordinate, joint: jb, coordinate: tx, stiffness: 1.0e6}]\n"
            "analysis: {type: modes, eigenvalues: 2}\n")
h = mt.history(run("slow_and_fast", f"{args.work_dir}/slow_and_fast.yaml", ranks=1))
check.true(f"slow and fast slides: no mode rigid ({h['rigid_mode'].tolist()})", h["rigid_mode"].tolist() == [0, 0])
check.less("slow and fast slides: largest |omega^2 / (k/m) - 1|", float(np.max(np.abs(h["eigenvalue"] / np.array([1e-8, 1e6]) - 1))), 1e-9)

# Preloaded beam: tension, and compression by half the Euler load of the weak axis.
euler = math.pi**2 * EI2 / L**2
tension_input = f"{inputs}/tension_modes.yaml"
compression_input = f"{args.work_dir}/compression_modes.yaml"
with open(tension_input) as source, open(compression_input, "w") as target:
    target.write(source.read().replace("force: [1.0e4, 0, 0]", f"force: [{-0.5 * euler!r}, 0, 0]"))
for name, input_file, T in (("tension", tension_input, 1.0e4), ("compression", compression_input, -0.5 * euler)):
    path = run(name, input_file, ranks=1)
    runs.append((name, input_file, ()))
    expected = [math.sqrt(((n * math.pi / L) ** 4 * EI + (n * math.pi / L) ** 2 * T) / RHO_A) for EI in (EI2, EI3) for n in range(1, 6)]
    compare(f"{name} T = {T:.6g}", mt.history(path)["angular_frequency"], expected, 1e-4, count=5)

# The same eigenvalues on more ranks.
runs += [("column_buckling", f"{inputs}/euler_column.yaml", ("-analysis_type", "buckling", "-analysis_eigenvalues", "2")),
         ("ltb_buckling", f"{inputs}/lateral_torsional.yaml", ("-analysis_type", "buckling", "-analysis_eigenvalues", "1"))]
if args.np > 1:
    for name, input_file, extra in runs:
        a, b = mt.history(run(name, input_file, extra, ranks=1)), mt.history(run(name, input_file, extra, ranks=args.np))
        other_order = mt.history(run(f"{name}_amd", input_file, (*extra, "-st_mat_mumps_icntl_7", "0"), ranks=1))
        # Elastic modes relative to each eigenvalue; rigid modes (their eigenvalues are round-off)
        # must be rigid on both.
        rigid_a = a.get("rigid_mode", np.zeros_like(a["eigenvalue"])) == 1
        rigid_b = b.get("rigid_mode", np.zeros_like(b["eigenvalue"])) == 1
        same = len(rigid_a) == len(rigid_b) and np.array_equal(rigid_a, rigid_b)
        check.true(f"{name}: the same modes, rigid ones the same, on np 1 and np {args.np}", bool(same))
        if same and len(other_order["eigenvalue"]) == len(a["eigenvalue"]):
            difference = np.abs(b["eigenvalue"] - a["eigenvalue"]) / np.abs(a["eigenvalue"])
            spread = (np.abs(other_order["eigenvalue"] - a["eigenvalue"]) / np.abs(a["eigenvalue"]))[~rigid_a].max()
            limit = max(1e-8, 4 * spread)
            print(f"{name}: np 1 vs np {args.np} {difference[~rigid_a].max():.3e}; two orderings on one rank {spread:.3e}")
            check.less(f"{name}: max relative eigenvalue difference np 1 vs np {args.np}", difference[~rigid_a].max(), limit)

# -eps_nev is the number of modes (it replaces analysis.eigenvalues); no more modes than unknowns.
for nev in (3, 20):
    h = mt.history(run(f"cantilever_nev{nev}", f"{inputs}/cantilever_modes.yaml", ("-eps_nev", str(nev)), ranks=1))
    check.equal(f"cantilever with -eps_nev {nev}: modes written", len(h["eigenvalue"]), nev)
tiny = f"{args.work_dir}/two_elements.yaml"
with open(f"{inputs}/cantilever_modes.yaml") as f:
    text = f.read()
import re  # noqa: E402
with open(tiny, "w") as f:
    f.write(re.sub(r"elements: *\d+", "elements: 1", text, count=1))
code, stdout, _ = mt.run_msflex(args, tiny, f"{args.work_dir}/tiny_modes.h5", extra=["-analysis_eigenvalues", "500"], np_ranks=1)
h = mt.history(f"{args.work_dir}/tiny_modes.h5")
said = re.search(r"500 modes asked for, but the model has (\d+) unknowns: computing \1", stdout)
print(f"500 modes of a one-element cantilever: {len(h['eigenvalue'])} written; {said.group(0) if said else 'no line'}")
check.true("500 modes asked of a one-element cantilever: the run says it computes as many as its 12 unknowns", bool(said) and said.group(1) == "12")
check.true("500 modes asked of a one-element cantilever: no more modes written than unknowns", 1 <= len(h["eigenvalue"]) <= 12)
# A spectral transformation that factors a singular matrix (-st_type shift: K itself, on a free
# beam with its rigid modes) stops with one line instead of MUMPS' trace and exit 76.
code, _, stderr = mt.run_msflex(args, f"{inputs}/free_free_modes.yaml", f"{args.work_dir}/shift_free.h5", extra=["-st_type", "shift"], np_ranks=1,
                                expect_success=False)
lines = [line for line in stderr.splitlines() if line.startswith("msflex:")]
print("-st_type shift on a free beam:", lines[:1])
check.equal("-st_type shift on a free beam: exit status", code, 1)
check.true("-st_type shift on a free beam: one line naming the singular factorisation", len(lines) == 1 and "is singular" in lines[0])
check.equal("-st_type shift on a free beam: PETSc trace-back lines", stderr.count("PETSC ERROR"), 0)

# Spectral transformations and solvers chosen by option that cannot deliver (on the portal frame,
# whose every motion has mass): one line each, exit 1, no trace-back (before: -st_type shift on a supported model wrote "0 modes" and exit 0,
# -st_type cayley ended in a PETSc trace and MPI_Abort, -eps_type lobpcg was said to factor a
# singular matrix); -st_type cayley, which failed the same way, now delivers.
for option, fragment in ((["-st_type", "shift"], "found 0 of the 4 modes asked for"),
                         (["-eps_type", "lobpcg"], "SLEPc: This solver supports only smallest real or largest real eigenvalues")):
    code, _, stderr = mt.run_msflex(args, f"{inputs}/preloaded_portal.yaml", f"{args.work_dir}/option_{option[1]}.h5", extra=option + ["-analysis_preload", "false"],
                                    np_ranks=1, expect_success=False)
    lines = [line for line in stderr.splitlines() if line.startswith("msflex:")]
    print(f"{' '.join(option)}: {lines[:1]}")
    check.equal(f"{' '.join(option)}: exit status", code, 1)
    check.true(f"{' '.join(option)}: one line naming why", len(lines) == 1 and fragment in lines[0])
    check.equal(f"{' '.join(option)}: PETSc trace-back lines", stderr.count("PETSC ERROR"), 0)

# -st_type cayley fails at shift 0 ("the inner product is not well defined") and went on to fail at
# the diagonal-ratio shift, -5.1e4; at the round-off shift it works, and the shift below the first
# eigenvalue it then takes gives the default's eigenvalues to Cayley's accuracy (3e-5 of the first).
cayley = mt.history(run("option_cayley", f"{inputs}/preloaded_portal.yaml", ["-st_type", "cayley", "-analysis_preload", "false"], ranks=1))
default = mt.history(run("option_default", f"{inputs}/preloaded_portal.yaml", ["-analysis_preload", "false"], ranks=1))
check.less("-st_type cayley: largest relative difference from the default's eigenvalues",
           float(np.max(np.abs(cayley["eigenvalue"] / default["eigenvalue"][:len(cayley["eigenvalue"])] - 1))), 1e-4)

# The slender wire: real low frequencies are not rigid modes.
h = mt.history(run("slender_wire", f"{inputs}/slender_wire.yaml", ranks=1))
rho_A, EI, length = 7850 * 7.85e-7, 1.03e-2, 2.0
first = (CANTILEVER[0] / length) ** 4 * EI / rho_A
check.less("slender wire: |first eigenvalue / (beta_1/L)^4 EI/rhoA - 1|", abs(h["eigenvalue"][0] / first - 1.0), 1e-4)
check.true("slender wire: no mode flagged rigid", bool(np.all(h["rigid_mode"] == 0)))
check.less("slender wire: |frequency - sqrt(eigenvalue)/(2 pi)| (Hz)", abs(h["frequency"][0] - math.sqrt(h["eigenvalue"][0]) / (2 * math.pi)), 1e-12)

# The preloaded portal frame: its sway frequency near buckling is elastic, omega^2 = omega_0^2
# (1 - lambda / lambda_cr), with omega_0^2 from the unloaded frame and lambda_cr from msflex's
# buckling analysis of the same model.
portal = f"{inputs}/preloaded_portal.yaml"
unloaded = mt.history(run("portal_unloaded", portal, ranks=1, extra=["-analysis_preload", "false"]))
critical = mt.history(run("portal_buckling", portal, ranks=1, extra=["-analysis_type", "buckling", "-analysis_preload", "false"]))["load_factor"][0]
print(f"portal frame: omega_0^2 = {unloaded['eigenvalue'][0]:.9g}, lambda_cr = {critical:.9g} (closed form 1.82129)")
check.less("portal frame: |lambda_cr / 1.82129 - 1| (k H tan k H = 6)", abs(critical / 1.82129 - 1), 1e-4)
for load in (1.0, 1.8, 1.81):
    h = mt.history(run(f"portal_{load}", portal, ranks=1, extra=["-analysis_end_time", str(load)]))
    expected = unloaded["eigenvalue"][0] * (1 - load / critical)
    check.true(f"portal frame at lambda = {load}: the sway mode is not flagged rigid", bool(h["rigid_mode"][0] == 0))
    check.less(f"portal frame at lambda = {load}: |omega^2 / (omega_0^2 (1 - lambda/lambda_cr)) - 1|", abs(h["eigenvalue"][0] / expected - 1), 2e-2)
# The hinged beam refined to 8000 quadratic elements, whose assembly rounding puts its rigid mode at
# lambda = -23 and moves its first bending eigenvalue by 20 (7706 against 7726.6): the first bending
# mode stood below 30 times its own round-off estimate, and 30 times it flagged it rigid (frequency 0).
with open(f"{args.source_dir}/input/hinged_beam_modes.yaml") as f:
    fine = f.read().split("expected:")[0].replace("elements: 48", "elements: 8000").replace("eigenvalues: 8", "eigenvalues: 3")
with open(f"{args.work_dir}/hinged_fine.yaml", "w") as f:
    f.write(fine)
h = mt.history(run("hinged_fine", f"{args.work_dir}/hinged_fine.yaml", ranks=1))
check.true(f"hinged beam, 8000 elements: only the first mode is rigid ({h['rigid_mode'].tolist()})", h["rigid_mode"].tolist() == [1, 0, 0])
first = (1.875104068711961 / 2.0) ** 2 * math.sqrt(1.0e4)
check.less("hinged beam, 8000 elements: |omega_1 / clamped-free (1.8751/L)^2 sqrt(EI2/rhoA) - 1|", abs(h["angular_frequency"][1] / first - 1), 5e-3)

# Non-conservative loads make the pencil non-symmetric, and the symmetric eigensolvers answered with
# load factors that changed with the rank count (a cantilever under an end moment of fixed direction:
# 51.8, 42.8 and 57.3 on 1, 2 and 4 ranks, exit 0): refused in one line, on 1 and --np ranks; the
# same column without the moment still buckles (the end load alone is conservative).
with open(f"{args.work_dir}/end_moment.yaml", "w") as f:
    f.write("""sections: [{name: s, EA: 1.0e6, GA2: 4.0e5, GA3: 4.0e5, GJ: 50, EI2: 80, EI3: 100}]
nodes: {a: [0, 0, 0], b: [2, 0, 0]}
beams: [{name: col, section: s, from: a, to: b, elements: 16}]
supports: [{nodes: a, fix: all}]
loads: [{nodes: b, force: [-1, 0, 0], moment: [0, 0, 0.5]}]
analysis: {type: buckling, eigenvalues: 2}
""")
for ranks in sorted({1, args.np}):
    code, _, stderr = mt.run_msflex(args, f"{args.work_dir}/end_moment.yaml", f"{args.work_dir}/end_moment_{ranks}.h5", np_ranks=ranks, expect_success=False)
    lines = [line for line in stderr.splitlines() if line.startswith("msflex:")]
    print(f"end moment of fixed direction, {ranks} rank(s): exit {code}: {lines[:1]}")
    check.equal(f"end moment of fixed direction, {ranks} rank(s): exit status", code, 1)
    check.true(f"end moment of fixed direction, {ranks} rank(s): one line saying the load stiffness is not symmetric",
               len(lines) == 1 and "buckling analysis: the load stiffness K_sigma is not symmetric" in lines[0])
with open(f"{args.work_dir}/end_moment.yaml") as f:
    conservative = f.read().replace(", moment: [0, 0, 0.5]", "")
with open(f"{args.work_dir}/end_force.yaml", "w") as f:
    f.write(conservative)
h = mt.history(run("end_force", f"{args.work_dir}/end_force.yaml", ranks=1))
euler = math.pi ** 2 * 80 / (4 * 2.0 ** 2)  # clamped-free, EI2 = 80 the weaker plane
check.less("end force alone: |first load factor / Euler's pi^2 EI / (4 L^2) - 1|", abs(h["load_factor"][0] / euler - 1), 2e-3)
check.finish()
