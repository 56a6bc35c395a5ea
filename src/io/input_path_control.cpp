// Checks of the analysis settings that refer to the rest of the model: the node DOF or joint
// coordinate that displacement control drives (analysis.control_node / control_joint and
// control_dof), and the keys that only some analyses or controls take. Shared by the reader
// (errors at the offending key) and the options (-analysis_* overrides, one-line errors).
#include "io/input_reader.hpp"
#include "io/input_reader_internal.hpp"
#include "model/joint_geometry.hpp"

namespace msflex::input_detail {

namespace {

const char *const kJointCoordinateNames[6] = {"tx", "ty", "tz", "rx", "ry", "rz"};

int FindNode(const Model &model, const std::string &name)
{
  for (size_t i = 0; i < model.nodes.size(); ++i)
    if (model.nodes[i].name == name) return (int)i;
  return -1;
}

int FindJoint(const Model &model, const std::string &name)
{
  for (size_t j = 0; j < model.joints.size(); ++j)
    if (model.joints[j].name == name) return (int)j;
  return -1;
}

} // namespace

int PathControlDofFromName(const std::string &name)
{
  for (int k = 0; k < 6; ++k)
    if (name == DofName(k) || name == kJointCoordinateNames[k]) return k;
  return -1;
}

AnalysisProblem PathControlProblem(const Model &model)
{
  const AnalysisSettings &a = model.analysis;
  // Statics with multigrid: the stability account and the bordered solves of arc-length and
  // displacement control factor the tangent, which is what multigrid is there to avoid.
  if (a.linear_solver == LinearSolverKind::Multigrid && a.type == AnalysisType::Static) {
    if (a.stability)
      return {"linear_solver",
              "'linear_solver: multigrid' in statics needs 'stability: false': the stability account factors the tangent at every equilibrium"};
    if (a.control != PathControl::Load)
      return {"linear_solver", std::string("'linear_solver: multigrid' in statics needs 'control: load', not ") + PathControlName(a.control) +
                                   ": path following solves its bordered systems with the direct solver"};
  }
  if (a.control != PathControl::Displacement) return {};
  const bool node = !a.control_node.empty(), joint = !a.control_joint.empty();
  if (node == joint)
    return {node ? "control_joint" : "control", node ? "give either 'control_node' or 'control_joint' for displacement control, not both"
                                                     : "displacement control needs the node ('control_node') or the joint ('control_joint') it drives"};
  if (a.control_dof < 0) return {node ? "control_node" : "control_joint", "displacement control needs 'control_dof': the DOF or joint coordinate it drives"};
  if (node) {
    const std::string dof = DofName(a.control_dof);
    const int         n   = FindNode(model, a.control_node);
    if (n < 0) return {"control_node", "unknown node " + Quote(a.control_node) + " in 'control_node'"};
    for (const Joint &j : model.joints)
      if (j.slave == n)
        return {"control_node", "node " + Quote(a.control_node) + " is the slave of joint " + Quote(j.name) +
                                    (j.master < 0 ? ": control one of the joint's coordinates ('control_joint') instead (its master is the ground)"
                                                  : ": control its master or one of the joint's coordinates ('control_joint') instead")};
    for (const Support &support : model.supports)
      for (int s : support.nodes)
        if (s == n && support.kind[a.control_dof] != Support::Kind::Free)
          return {"control_dof", "DOF " + dof + " of node " + Quote(a.control_node) + " is " +
                                     (support.kind[a.control_dof] == Support::Kind::Fixed ? "fixed" : "prescribed") +
                                     " by a support: displacement control needs a free DOF"};
  } else {
    const int j = FindJoint(model, a.control_joint);
    if (j < 0) return {"control_joint", "unknown joint " + Quote(a.control_joint) + " in 'control_joint'"};
    const Joint      &joint = model.joints[j];
    const int         c     = JointCoordinateOfAxis(joint, a.control_dof);
    const std::string dof   = kJointCoordinateNames[a.control_dof];
    if (c < 0)
      return {"control_dof", "joint " + Quote(joint.name) + " (" + JointKindName(joint.kind) + ") has no coordinate " + dof + " (a " +
                                 (a.control_dof < 3 ? "translation along" : "rotation about") + " its axis a" + std::to_string(a.control_dof % 3 + 1) +
                                 "); displacement control drives a released coordinate"};
    if (joint.driven_coordinate == c) return {"control_dof", "coordinate " + dof + " of joint " + Quote(joint.name) + " is driven by its 'drive'"};
  }
  return {};
}

} // namespace msflex::input_detail

namespace msflex {

bool CheckAnalysisSettings(const Model &model, InputError *error)
{
  using namespace input_detail;
  const AnalysisProblem problem = PathControlProblem(model);
  if (problem.message.empty()) return true;
  *error = InputError{model.input_file, model.analysis.mark.line, model.analysis.mark.column, problem.message};
  return false;
}

int PathControlDof(const std::string &name) { return input_detail::PathControlDofFromName(name); }

std::string PathControlDofMismatch(const std::string &name, bool joint)
{
  if (joint && !name.empty() && name[0] == 'u')
    return "'control_dof' " + input_detail::Quote(name) +
           " names a node's DOF; a joint's coordinates are tx, ty, tz (along its axes a1, a2, a3) and rx, ry, rz";
  if (!joint && !name.empty() && name[0] == 't')
    return "'control_dof' " + input_detail::Quote(name) + " names a joint's coordinate; a node's DOFs are ux, uy, uz, rx, ry, rz (global axes)";
  return "";
}

} // namespace msflex
