// The registry of joint kinds: the one place that names them and fixes what each releases, read by
// the input reader (YAML and mesh files), -help, the output and the documentation test.
//
// A kind releases translations along and rotations about its joint axes a1 a2 a3 (docs/joints.md);
// screw, rack_pinion and cam make a translation depend on the single rotation; custom takes its
// releases from the input, cam_table its profile.
#pragma once

#include "joints/joint_kinematics.hpp"

#include <string>

namespace msflex {

enum class JointKind { Rigid, Spherical, Revolute, Universal, Cylindrical, Prismatic, Planar, Free, Custom, Screw, RackPinion, Cam, CamTable };

// The input key a kind needs besides its axes.
enum class JointParameter { None, Pitch, Radius, Release, Profile };

struct JointKindInfo {
  const char     *name;
  JointKind       kind;
  JointParameter  parameter;
  const char     *description;
  int             num_translations; // released translations along translation_axes[0..n)
  int             translation_axes[3];
  int             num_rotations; // 0, 1 (about rotation_axes[0]), 2 (Cardan: [0] then [1]) or 3 (free)
  int             rotation_axes[2];
  JointDependence dependence; // a translation along dependent_axis that follows the rotation
  int             dependent_axis;
};

const JointKindInfo *JointKinds(int *count);
// The kind of a registered name, or null.
const JointKindInfo *JointKindFind(const std::string &name);
const JointKindInfo &JointKindInfoOf(JointKind kind);
const char          *JointKindName(JointKind kind);
// "rigid, spherical, ..., cam_table": the registered names, for messages.
std::string JointKindNameList();

} // namespace msflex
