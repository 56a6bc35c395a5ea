// Micro-benchmark of the beam kernels: microseconds per element for the residual alone and for the
// residual with the tangent and the strain energy (the call the Jacobian assembly makes), for 2-
// and 3-node elements in a deformed state with finite rotations (a curved, twisted reference
// turned by a large rigid rotation plus nodal perturbations); then the mid-point kernel of the
// conserving schemes from the reference (start of the step) to that state, as the residual and
// the tangent assemblies of mc (F_mc, F_corr, K_mc) and em (also K_corr and the end residual)
// call it, and em's residual and tangent visits as its assembly makes them (the start of the step
// evaluated once, the iterate kept between the two visits). Prints the median and the minimum
// over rounds of thread CPU time; asserts nothing.
// Run through scripts/bench-kernel.
#include "elements/beam.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <vector>

using namespace msflex;

namespace {

struct Configuration {
  Vec3 positions[kBeamMaxNodes];
  Mat3 triads[kBeamMaxNodes];
};

// Reference on an arc of radius 2 with a twisting triad; the deformed state adds a rigid rotation
// and translation and perturbations of a tenth of the element size.
void MakeElement(int num_nodes, Configuration *reference, Configuration *deformed)
{
  const Mat3 Q = ExpSO3(Vec3(1.1, -0.7, 0.4));
  for (int a = 0; a < num_nodes; ++a) {
    const double phi = 0.3 * a / (num_nodes - 1);
    const Vec3   t1  = Vec3(std::cos(phi), std::sin(phi), 0.05).normalized();
    Vec3         t2  = Vec3(-std::sin(phi), std::cos(phi), 0.0);
    t2               = (t2 - t2.dot(t1) * t1).normalized();
    Mat3 T;
    T.col(0)                = t1;
    T.col(1)                = t2;
    T.col(2)                = t1.cross(t2);
    reference->positions[a] = Vec3(2.0 * std::sin(phi), 2.0 * (1 - std::cos(phi)), 0.1 * phi);
    reference->triads[a]    = ExpSO3(0.3 * a * t1) * T;
    const Vec3 dx(0.02 * a, -0.01 * a, 0.015 * a), dtheta(0.05 * a, 0.1 * a, -0.07 * a);
    deformed->positions[a] = Q * reference->positions[a] + Vec3(3.0, -2.0, 1.0) + dx;
    deformed->triads[a]    = ExpSO3(dtheta) * Q * reference->triads[a];
  }
}

// CPU time of this thread: on a shared, loaded machine it leaves out the time other processes run.
double ThreadSeconds()
{
  timespec t;
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
  return t.tv_sec + 1e-9 * t.tv_nsec;
}

double Median(std::vector<double> v)
{
  std::sort(v.begin(), v.end());
  return v[v.size() / 2];
}

} // namespace

int main(int argc, char **argv)
{
  const int                     rounds = argc > 1 ? std::atoi(argv[1]) : 15, repetitions = 20000;
  const BeamSectionStiffness    section{Vec3(1e4, 3e3, 5e3), Vec3(700, 400, 900)};
  double                        checksum = 0.0;
  static BeamMidpointIterate<2> kept_two;
  static BeamMidpointIterate<3> kept_three;
  std::printf("%6s %-24s %10s %10s\n", "nodes", "call", "median_us", "min_us");
  // Optional: only one element size and call (for counting instructions): [rounds] [nodes] [0|1 tangent]
  const int only_nodes = argc > 2 ? std::atoi(argv[2]) : 0, only_tangent = argc > 3 ? std::atoi(argv[3]) : -1;
  for (int nn = 2; nn <= 3; ++nn) {
    if (only_nodes && nn != only_nodes) continue;
    Configuration reference, deformed;
    MakeElement(nn, &reference, &deformed);
    BeamElementReference ref;
    if (BeamElementSetup(nn, reference.positions, reference.triads, &ref) != BeamKernelStatus::Ok) return 1;
    double residual[kBeamMaxDofs], tangent[kBeamMaxDofs * kBeamMaxDofs], energy = 0.0;
    for (int with_tangent = 0; with_tangent < 2; ++with_tangent) {
      if (only_tangent >= 0 && with_tangent != only_tangent) continue;
      std::vector<double> per_call;
      for (int round = 0; round < rounds; ++round) {
        const double start = ThreadSeconds();
        for (int i = 0; i < repetitions; ++i) {
          // Move one coordinate a little so the call cannot be hoisted out of the loop.
          deformed.positions[1](0) += 1e-12;
          BeamInternalForces(ref, section, deformed.positions, deformed.triads, residual, with_tangent ? tangent : nullptr, &energy, nullptr);
          checksum += residual[0] + (with_tangent ? tangent[7] : 0.0) + energy;
        }
        const double stop = ThreadSeconds();
        per_call.push_back(1e6 * (stop - start) / repetitions);
      }
      std::printf("%6d %-24s %10.3f %10.3f\n", nn, with_tangent ? "residual+tangent+energy" : "residual+energy", Median(per_call),
                  *std::min_element(per_call.begin(), per_call.end()));
    }
    if (only_nodes || only_tangent >= 0) continue;
    // Mid-point kernel: 0 the residual pass, 1 mc's tangent pass, 2 em's tangent pass (K_mc and
    // K_corr apart), 3 em's tangent pass with beta known (K_mc + beta K_corr at once).
    const char *const midpoint_calls[4] = {"midpoint residual", "midpoint mc tangent", "midpoint em tangent", "midpoint em, beta known"};
    const double      beta              = 0.3;
    double            correction[kBeamMaxDofs], tangent_correction[kBeamMaxDofs * kBeamMaxDofs], end_residual[kBeamMaxDofs], energy_start = 0.0;
    for (int call = 0; call < 4; ++call) {
      std::vector<double> per_call;
      for (int round = 0; round < rounds; ++round) {
        const double start = ThreadSeconds();
        for (int i = 0; i < repetitions; ++i) {
          deformed.positions[1](0) += 1e-12;
          // mc's tangent pass has no use for F_corr (call 1 passes none); em's passes do.
          BeamMidpointInternalForces(ref, section, reference.positions, reference.triads, deformed.positions, deformed.triads, residual,
                                     call == 1 ? nullptr : correction, call >= 1 ? tangent : nullptr, call == 2 ? tangent_correction : nullptr,
                                     call >= 2 ? end_residual : nullptr, &energy_start, &energy, EnergyCorrection::Resultants, call == 3 ? &beta : nullptr);
          checksum += residual[0] + (call == 1 ? 0.0 : correction[1]) + (call >= 1 ? tangent[7] : 0.0) + (call == 2 ? tangent_correction[8] : 0.0) +
                      (call >= 2 ? end_residual[2] : 0.0) + energy;
        }
        const double stop = ThreadSeconds();
        per_call.push_back(1e6 * (stop - start) / repetitions);
      }
      std::printf("%6d %-24s %10.3f %10.3f\n", nn, midpoint_calls[call], Median(per_call), *std::min_element(per_call.begin(), per_call.end()));
    }
    // em as its assembly calls it, with the step's start evaluated once (BeginStep): 0 the residual
    // pass that keeps the iterate, 1 the tangent pass from the kept iterate with beta known, 2 a
    // residual that no tangent follows (the converged iterate's).
    BeamMidpointStart start;
    if (BeamMidpointStartState(ref, reference.positions, reference.triads, &start) != BeamKernelStatus::Ok) return 1;
    const char *const em_calls[3] = {"em residual, keeping", "em tangent of kept", "em residual alone"};
    for (int call = 0; call < 3; ++call) {
      std::vector<double> per_call;
      for (int round = 0; round < rounds; ++round) {
        const double start_time = ThreadSeconds();
        for (int i = 0; i < repetitions; ++i) {
          deformed.positions[1](0) += 1e-12;
          if (call == 2) {
            BeamMidpointInternalForces(ref, section, reference.positions, reference.triads, deformed.positions, deformed.triads, residual, correction, nullptr,
                                       nullptr, nullptr, &energy_start, &energy, EnergyCorrection::Resultants, nullptr, &start);
            checksum += residual[0] + correction[1] + energy;
            continue;
          }
          if (nn == 2) {
            if (call == 0)
              BeamMidpointResidualKeeping<2>(ref, section, start, deformed.positions, deformed.triads, residual, correction, end_residual, &energy_start,
                                             &energy, EnergyCorrection::Resultants, &kept_two);
            else BeamMidpointTangentOfIterate<2>(ref, section, kept_two, EnergyCorrection::Resultants, &beta, tangent, nullptr);
          } else {
            if (call == 0)
              BeamMidpointResidualKeeping<3>(ref, section, start, deformed.positions, deformed.triads, residual, correction, end_residual, &energy_start,
                                             &energy, EnergyCorrection::Resultants, &kept_three);
            else BeamMidpointTangentOfIterate<3>(ref, section, kept_three, EnergyCorrection::Resultants, &beta, tangent, nullptr);
          }
          checksum += call == 0 ? residual[0] + correction[1] + end_residual[2] + energy : tangent[7];
        }
        const double stop = ThreadSeconds();
        per_call.push_back(1e6 * (stop - start_time) / repetitions);
      }
      std::printf("%6d %-24s %10.3f %10.3f\n", nn, em_calls[call], Median(per_call), *std::min_element(per_call.begin(), per_call.end()));
    }
  }
  std::printf("checksum %.6e\n", checksum);
  return std::isfinite(checksum) ? 0 : 1;
}
