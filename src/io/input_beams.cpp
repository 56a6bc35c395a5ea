// Reading `beams`: each straight line or circular arc becomes a chain of nodes and elements with
// reference section triads (docs/input.md, "beams").
#include "io/input_reader_internal.hpp"

#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <utility>

namespace msflex::input_detail {

namespace {

// The reference curve of a beam before roll and twist: position and triad (columns t1 = tangent,
// t2, t3) as functions of the arc-length fraction s/L in [0, 1].
struct ReferenceCurve {
  Vec3   start       = Vec3::Zero();
  Vec3   end         = Vec3::Zero();
  Mat3   start_triad = Mat3::Identity();
  bool   is_arc      = false;
  Vec3   center      = Vec3::Zero();  // arcs: centre of the circle
  Vec3   normal      = Vec3::UnitZ(); // arcs: unit axis; the arc turns counter-clockwise about it
  double sweep_angle = 0.0;           // arcs: in (0, 2 pi)

  Vec3 PositionAt(double fraction) const
  {
    if (!is_arc) return start + fraction * (end - start);
    return center + ExpSO3(fraction * sweep_angle * normal) * (start - center);
  }
  // On an arc the start triad turns with the radius, so t1 stays tangent and t2 keeps pointing
  // at the centre.
  Mat3 TriadAt(double fraction) const
  {
    if (!is_arc) return start_triad;
    return ExpSO3(fraction * sweep_angle * normal) * start_triad;
  }
};

// v / |v| for any finite non-zero v: stableNorm neither overflows (1e200) nor underflows (1e-200),
// where normalized() would return a zero or infinite vector.
Vec3 UnitVector(const Vec3 &v) { return v / v.stableNorm(); }

// Columns t1, t2 and t3 = t1 x t2 for orthonormal t1, t2.
Mat3 TriadFromAxes(const Vec3 &t1, const Vec3 &t2)
{
  Mat3 triad;
  triad.col(0) = t1;
  triad.col(1) = t2;
  triad.col(2) = t1.cross(t2);
  return triad;
}

// Straight beam: t1 along the axis, t2 the part of `orientation` across the axis (checked by the
// caller with OrientationAlongAxis).
ReferenceCurve StraightCurve(const Vec3 &start, const Vec3 &end, const Vec3 &orientation)
{
  const Vec3     axis = UnitVector(end - start);
  const Vec3     v    = UnitVector(orientation);
  ReferenceCurve curve;
  curve.start       = start;
  curve.end         = end;
  curve.start_triad = TriadFromAxes(axis, (v - v.dot(axis) * axis).normalized());
  return curve;
}

// `orientation` of a YAML line beam, or the default.
Vec3 ReadLineOrientation(const MappingReader &beam, const Vec3 &start, const Vec3 &end)
{
  const YAML::Node *value = beam.Find("orientation");
  if (value == nullptr) return DefaultBeamOrientation(start, end);
  const Vec3 orientation = ReadVec3(*value, "orientation");
  if (orientation.stableNorm() == 0.0) FailAt(value->Mark(), "'orientation' of " + beam.Description() + " must not be the zero vector");
  if (OrientationAlongAxis(orientation, start, end))
    FailAt(value->Mark(), "'orientation' " + FormatVec3(orientation) + " is parallel to the axis of " + beam.Description() + "; it must point across the beam");
  return orientation;
}

Vec3 ArcNormal(const MappingReader &arc, const Vec3 &start_radius, const Vec3 &end_radius)
{
  const YAML::Node *value = arc.Find("normal");
  if (value == nullptr) {
    const Vec3 plane_normal = start_radius.cross(end_radius);
    if (plane_normal.norm() <= 1e-9 * start_radius.norm() * end_radius.norm())
      FailAt(arc.Mark(), "'from', 'to' and 'center' are collinear in " + arc.Description() + ", so the plane of the arc is undefined; give 'normal'");
    return plane_normal.normalized();
  }
  const Vec3 normal = ReadVec3(*value, "normal");
  if (normal.stableNorm() == 0.0) FailAt(value->Mark(), "'normal' of " + arc.Description() + " must not be the zero vector");
  const Vec3 unit_normal = UnitVector(normal);
  if (std::abs(unit_normal.dot(start_radius)) > 1e-9 * start_radius.norm())
    FailAt(value->Mark(), "'normal' " + FormatVec3(normal) + " of " + arc.Description() + " is not perpendicular to from - center");
  // Otherwise `to` would lie off the plane of the arc and the arc could not reach it.
  if (std::abs(unit_normal.dot(end_radius)) > 1e-9 * end_radius.norm())
    FailAt(value->Mark(), "'normal' " + FormatVec3(normal) + " of " + arc.Description() + " is not perpendicular to to - center");
  return unit_normal;
}

ReferenceCurve ArcCurve(const YAML::Node &arc_node, const MappingReader &beam, const Vec3 &start, const Vec3 &end)
{
  const MappingReader arc(arc_node, "'arc' of " + beam.Description(), {"center", "normal"});
  ReferenceCurve      curve;
  curve.is_arc              = true;
  curve.start               = start;
  curve.end                 = end;
  curve.center              = ReadPosition(arc.Required("center"), "center");
  const Vec3   start_radius = start - curve.center;
  const Vec3   end_radius   = end - curve.center;
  const double radius       = start_radius.norm();
  // Also rejects a zero radius: from != to, so at most one of them can sit on the centre.
  if (std::abs(radius - end_radius.norm()) > 1e-9 * std::max(radius, end_radius.norm()))
    FailAt(arc.Required("center").Mark(), "'from' and 'to' of " + beam.Description() + " are not equally far from 'center' " + FormatVec3(curve.center) + ": " +
                                              FormatNumber(radius) + " and " + FormatNumber(end_radius.norm()));
  curve.normal      = ArcNormal(arc, start_radius, end_radius);
  curve.sweep_angle = std::atan2(curve.normal.dot(start_radius.cross(end_radius)), start_radius.dot(end_radius));
  if (curve.sweep_angle <= 0.0) curve.sweep_angle += 2.0 * M_PI;
  const Vec3 outward = start_radius / radius;
  curve.start_triad  = TriadFromAxes(curve.normal.cross(outward), -outward);
  return curve;
}

BeamLayout ReadLayout(const MappingReader &beam)
{
  BeamLayout layout;
  layout.elements = beam.Integer("elements", 1);
  if (layout.elements > kMaxElementsPerBeam)
    FailAt(beam.Required("elements").Mark(),
           "'elements' must be at most " + std::to_string(kMaxElementsPerBeam) + ", got " + beam.Required("elements").Scalar());
  layout.order = beam.Integer("order", 1, 1);
  if (layout.order > 2) FailAt(beam.Required("order").Mark(), "'order' must be 1 or 2, got " + beam.Required("order").Scalar());
  layout.roll  = beam.Number("roll", 0.0);
  layout.twist = beam.Number("twist", 0.0);
  return layout;
}

// Nodes equally spaced in arc length (the end nodes are the named ones), then the elements; then
// appends the beam to Model::beams.
void AppendNodesAndElements(const ReferenceCurve &curve, const BeamLayout &layout, int from, int to, Beam beam, ReaderContext &context)
{
  Model &model                 = context.model;
  beam.order                   = layout.order;
  const int         beam_index = static_cast<int>(model.beams.size());
  const int         segments   = layout.elements * layout.order;
  std::vector<Mat3> triads;
  for (int k = 0; k <= segments; ++k) {
    const double fraction = static_cast<double>(k) / segments;
    int          node     = k == 0 ? from : to;
    if (k > 0 && k < segments) {
      node = static_cast<int>(model.nodes.size());
      Node generated{beam.name + "." + std::to_string(k), curve.PositionAt(fraction), beam.mark};
      if (const auto clash = context.names.find(generated.name); clash != context.names.end())
        FailAt(beam.mark, "beam " + Quote(beam.name) + " generates node " + Quote(generated.name) + ", but that name is already used at line " +
                              std::to_string(clash->second.line));
      context.RegisterName(generated.name, NameKind::Node, node, beam.mark);
      model.nodes.push_back(std::move(generated));
    }
    beam.nodes.push_back(node);
    // Roll and twist turn t2 and t3 about t1, i.e. about the first axis of the section frame.
    triads.push_back(curve.TriadAt(fraction) * ExpSO3(Vec3(layout.roll + layout.twist * fraction, 0.0, 0.0)));
  }
  for (int element_index = 0; element_index < layout.elements; ++element_index) {
    BeamElement element;
    element.section = beam.section;
    element.order   = layout.order;
    element.beam    = beam_index;
    for (int a = 0; a <= layout.order; ++a) {
      const size_t along_beam     = static_cast<size_t>(element_index * layout.order + a);
      element.nodes[a]            = beam.nodes[along_beam];
      element.reference_triads[a] = triads[along_beam];
    }
    beam.elements.push_back(static_cast<int>(model.elements.size()));
    model.elements.push_back(element);
  }
  model.beams.push_back(std::move(beam));
}

void ReadBeam(const YAML::Node &item, ReaderContext &context)
{
  const MappingReader entry(item, "beam", {"name", "section", "from", "to", "elements", "order", "orientation", "roll", "twist", "arc"});
  Model              &model = context.model;
  Beam                beam;
  beam.name = entry.String("name");
  beam.mark = context.MarkOf(entry.Mark());
  context.RegisterName(beam.name, NameKind::Beam, static_cast<int>(model.beams.size()), context.MarkOf(entry.Required("name").Mark()));
  beam.section   = context.SectionIndex(entry, "section");
  const int from = context.NodeIndex(entry, "from");
  const int to   = context.NodeIndex(entry, "to");
  if (from == to)
    FailAt(entry.Required("to").Mark(), "'to' must differ from 'from' in " + entry.Description() + " (both are " + Quote(model.nodes[to].name) + ")");
  const Vec3 start = model.nodes[from].position;
  const Vec3 end   = model.nodes[to].position;
  if (BeamHasZeroLength(start, end))
    FailAt(entry.Required("to").Mark(), entry.Description() + " has zero length: nodes " + Quote(model.nodes[from].name) + " and " +
                                            Quote(model.nodes[to].name) + " are at the same position");
  const BeamLayout layout = ReadLayout(entry);
  if (const YAML::Node *arc = entry.Find("arc")) {
    // On an arc t2 is fixed by the geometry (towards the centre); `roll` rotates it instead.
    if (const YAML::Node *orientation = entry.Find("orientation"))
      FailAt(orientation->Mark(),
             "'orientation' cannot be combined with 'arc' in " + entry.Description() + " (on an arc t2 points to the centre; use 'roll' to turn the section)");
    AppendNodesAndElements(ArcCurve(*arc, entry, start, end), layout, from, to, std::move(beam), context);
  } else {
    AppendStraightBeam(std::move(beam), from, to, ReadLineOrientation(entry, start, end), layout, context);
  }
}

} // namespace

bool BeamHasZeroLength(const Vec3 &start, const Vec3 &end) { return (end - start).norm() <= 1e-12 * (1.0 + start.norm()); }

Vec3 DefaultBeamOrientation(const Vec3 &start, const Vec3 &end)
{
  // (0, 1, 0) is swapped for (-1, 0, 0) on nearly vertical (y) beams, where it would be almost
  // parallel to the axis.
  const Vec3 axis = UnitVector(end - start);
  return std::abs(axis.dot(Vec3::UnitY())) > 0.99 ? Vec3(-1.0, 0.0, 0.0) : Vec3::UnitY();
}

bool OrientationAlongAxis(const Vec3 &orientation, const Vec3 &start, const Vec3 &end)
{
  return UnitVector(orientation).cross(UnitVector(end - start)).norm() < 1e-8;
}

void AppendStraightBeam(Beam beam, int from, int to, const Vec3 &orientation, const BeamLayout &layout, ReaderContext &context)
{
  const Model &model = context.model;
  // YAML nodes are checked when read; this also covers the nodes of a mesh file.
  for (const int node : {from, to})
    if (const std::string problem = PositionProblem(model.nodes[node].position); !problem.empty())
      FailAt(beam.mark,
             "node " + Quote(model.nodes[node].name) + " of beam " + Quote(beam.name) + " is at " + FormatVec3(model.nodes[node].position) + ": " + problem);
  AppendNodesAndElements(StraightCurve(model.nodes[from].position, model.nodes[to].position, orientation), layout, from, to, std::move(beam), context);
}

void ReadBeams(const YAML::Node &beams, ReaderContext &context)
{
  for (const YAML::Node &item : ReadNonEmptyList(beams, "beams")) ReadBeam(item, context);
}

} // namespace msflex::input_detail
