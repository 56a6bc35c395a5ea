#include "model/joint_kinds.hpp"

namespace msflex {

namespace {
constexpr JointDependence kNone         = JointDependence::None;
const JointKindInfo       kJointKinds[] = {
          {"rigid", JointKind::Rigid, JointParameter::None, "no relative motion", 0, {0, 0, 0}, 0, {0, 0}, kNone, 0},
          {"spherical", JointKind::Spherical, JointParameter::None, "free relative rotation (ball joint)", 0, {0, 0, 0}, 3, {0, 0}, kNone, 0},
          {"revolute", JointKind::Revolute, JointParameter::None, "rotation rx about a1 (hinge)", 0, {0, 0, 0}, 1, {0, 0}, kNone, 0},
          {"universal",
           JointKind::Universal,
           JointParameter::None,
           "rotations rx about a1, then ry about the carried a2 (Cardan joint)",
           0,
           {0, 0, 0},
           2,
           {0, 1},
           kNone,
           0},
          {"cylindrical", JointKind::Cylindrical, JointParameter::None, "translation tx along and rotation rx about a1", 1, {0, 0, 0}, 1, {0, 0}, kNone, 0},
          {"prismatic", JointKind::Prismatic, JointParameter::None, "translation tx along a1 (slider)", 1, {0, 0, 0}, 0, {0, 0}, kNone, 0},
          {"planar",
           JointKind::Planar,
           JointParameter::None,
           "translations ty, tz in the plane normal to a1 and rotation rx about a1",
           2,
           {1, 2, 0},
           1,
           {0, 0},
           kNone,
           0},
          {"free", JointKind::Free, JointParameter::None, "every relative motion (tx ty tz and a free rotation)", 3, {0, 1, 2}, 3, {0, 0}, kNone, 0},
          {"custom", JointKind::Custom, JointParameter::Release, "the coordinates listed in 'release' (tx ty tz rx ry rz)", 0, {0, 0, 0}, 0, {0, 0}, kNone, 0},
          {"screw",
           JointKind::Screw,
           JointParameter::Pitch,
           "rotation rx about a1 with translation pitch * rx along a1",
           0,
           {0, 0, 0},
           1,
           {0, 0},
           JointDependence::Linear,
           0},
          {"rack_pinion",
           JointKind::RackPinion,
           JointParameter::Radius,
           "rotation rx about a1 with translation radius * rx along a2 (the rack)",
           0,
           {0, 0, 0},
           1,
           {0, 0},
           JointDependence::Linear,
           1},
          {"cam",
           JointKind::Cam,
           JointParameter::Radius,
           "rotation rx about a1 with lift radius (cos rx - 1) along a2 (eccentric cam)",
           0,
           {0, 0, 0},
           1,
           {0, 0},
           JointDependence::EccentricCam,
           1},
          {"cam_table",
           JointKind::CamTable,
           JointParameter::Profile,
           "rotation rx about a1 with a lift along a2 from a periodic spline 'profile'",
           0,
           {0, 0, 0},
           1,
           {0, 0},
           JointDependence::Table,
           1},
};
} // namespace

const JointKindInfo *JointKinds(int *count)
{
  *count = (int)(sizeof(kJointKinds) / sizeof(kJointKinds[0]));
  return kJointKinds;
}

const JointKindInfo *JointKindFind(const std::string &name)
{
  for (const JointKindInfo &info : kJointKinds)
    if (name == info.name) return &info;
  return nullptr;
}

const JointKindInfo &JointKindInfoOf(JointKind kind)
{
  for (const JointKindInfo &info : kJointKinds)
    if (info.kind == kind) return info;
  return kJointKinds[0];
}

const char *JointKindName(JointKind kind) { return JointKindInfoOf(kind).name; }

std::string JointKindNameList()
{
  std::string list;
  for (const JointKindInfo &info : kJointKinds) list += (list.empty() ? "" : ", ") + std::string(info.name);
  return list;
}

} // namespace msflex
