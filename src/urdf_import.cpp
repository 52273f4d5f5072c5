#include "wbm/urdf_import.hpp"

#include <sys/stat.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <fstream>
#include <limits>
#include <locale>
#include <map>
#include <set>
#include <sstream>

#include <tinyxml.h>
#include <urdf_parser/urdf_parser.h>

#include "wbm/errors.hpp"

#include "closest_names.hpp"
#include "console_capture.hpp"

namespace wbm {
namespace {

std::string quoted(const std::string& s) { return "'" + s + "'"; }

/// `s` with tabs, line breaks and carriage returns written as \t, \n and \r.
std::string escaped_whitespace(const std::string& s) {
  std::string out;
  for (const char c : s) out += c == '\t' ? "\\t" : c == '\n' ? "\\n" : c == '\r' ? "\\r" : std::string(1, c);
  return out;
}

/// Largest accepted |norm - 1| of a joint axis; accepted axes are normalised.
constexpr double kAxisNormTolerance = 0.01;

/// A revolute joint with both limits at least this far from zero [rad] is unlimited:
/// sdformat and the URDFs converted from SDF write +-1e16 for "no limit", others 1e10 or
/// the largest float. It is imported as continuous; kept as limits, its work range of
/// 2e16 rad would give it all of the weighting matrix W (section IV.C).
constexpr double kUnlimitedRevolute = 1e6;

enum class RevoluteLimits { kAngles, kOneSideUnlimited, kUnlimited };

RevoluteLimits classify_revolute_limits(double lower, double upper) {
  if (lower <= -kUnlimitedRevolute && upper >= kUnlimitedRevolute) return RevoluteLimits::kUnlimited;
  if (std::abs(lower) >= kUnlimitedRevolute || std::abs(upper) >= kUnlimitedRevolute)
    return RevoluteLimits::kOneSideUnlimited;
  return RevoluteLimits::kAngles;
}

/// Where an element of the file is, for messages "FILE:LINE: ...".
struct Located {
  std::string name;
  int line = 0;
};

struct JointInfo : Located {
  std::string type, parent, child, mimic;
  /// A missing position range or speed limit, found with legs given: an error only if the
  /// joint becomes a dof (a locked or dropped leg's joint never moves). line 0: none.
  struct {
    int line = 0;
    std::string message;
  } missing_limit;
};

/// A `<capsule>` of a link's collision or visual element (MuJoCo's primitive, written so in
/// URDFs converted from MJCF), which urdfdom drops with a message: kept here for the soles.
struct Capsule {
  Transform X_LG;  ///< its pose in the link's frame; its axis is its z axis
  double radius = 0.0, length = 0.0;
};

/// Structural check of the XML with line numbers, before urdfdom builds the model.
/// urdfdom reports errors without lines (and for some of them not at all), so every
/// error a user can make in the structure is caught here first.
class UrdfChecker {
 public:
  UrdfChecker(const std::string& xml, const std::string& source, const UrdfImportOptions& options)
      : source_(source), options_(options) {
    TiXmlDocument doc;
    doc.Parse(xml.c_str(), nullptr, TIXML_ENCODING_UTF8);
    if (doc.Error()) fail(doc.ErrorRow(), std::string("malformed XML: ") + doc.ErrorDesc());
    const TiXmlElement* robot = doc.RootElement();
    if (robot == nullptr) fail(1, "malformed XML: no root element");
    if (std::string(robot->Value()) != "robot")
      fail(robot->Row(), std::string("expected a <robot> root element, found <") + robot->Value() + ">");
    required(robot, "name", "robot");  // urdfdom rejects a nameless robot, without a line
    for (const TiXmlElement* e = robot->FirstChildElement(); e; e = e->NextSiblingElement()) check_xacro(e);
    for (const TiXmlElement* e = robot->FirstChildElement("link"); e; e = e->NextSiblingElement("link"))
      check_link(e);
    for (const TiXmlElement* e = robot->FirstChildElement("joint"); e; e = e->NextSiblingElement("joint"))
      check_joint(e);
    for (const TiXmlElement* e = robot->FirstChildElement("material"); e; e = e->NextSiblingElement("material"))
      check_numeric_attributes(e, "material " + quoted(e->Attribute("name") ? e->Attribute("name") : ""));
    if (links_.empty()) fail(robot->Row(), "<robot> has no <link>");
    check_tree();
  }

  /// Unexpanded xacro in a top-level element `e` of <robot>. A xacro element directly below
  /// <robot> is an error unless ignore_xacro_elements is set; then it is skipped (as urdfdom
  /// and kdl_parser skip every element they do not know) unless it makes a <link> or <joint>,
  /// which would be missing from the model. A xacro element inside a link, joint or material
  /// (e.g. `<xacro:insert_block name="origin"/>`) is an error either way, since it stands for
  /// part of that element; one inside any other element (<gazebo>, <transmission>), which wbm
  /// and urdfdom do not read, is passed over either way.
  void check_xacro(const TiXmlElement* e) const {
    const std::string tag = e->Value();
    const bool shapes_the_model = tag == "link" || tag == "joint" || tag == "material";
    if (is_xacro(e)) {
      if (!options_.ignore_xacro_elements)
        fail(e->Row(), "<" + tag + "> is a xacro element: expand the file first (`xacro robot.urdf.xacro > " +
                           "robot.urdf`, ROS's xacro), or, if every link and joint is written out in it, import " +
                           "with ignore_xacro_elements (--ignore-xacro-elements), which skips such elements");
      if (const TiXmlElement* inner = link_or_joint_made_by(e))
        fail(inner->Row(), "<" + std::string(inner->Value()) + "> inside <" + tag + "> (line " +
                               std::to_string(e->Row()) +
                               "): xacro makes links or joints here, which would be missing without it "
                               "(ignore_xacro_elements skips only elements that make none); expand the file "
                               "with xacro first");
      return;
    }
    if (shapes_the_model)
      if (const TiXmlElement* inner = first_xacro_below(e))
        fail(inner->Row(), "<" + std::string(inner->Value()) + "> inside <" + tag + "> (line " +
                               std::to_string(e->Row()) + ") is a xacro element: expand the file first (`xacro " +
                               "robot.urdf.xacro > robot.urdf`, ROS's xacro)");
  }

  static bool is_xacro(const TiXmlElement* e) { return std::string(e->Value()).rfind("xacro:", 0) == 0; }

  /// A <link> or <joint> that the xacro element `e` makes: a child of it or of the xacro
  /// elements inside it (`<xacro:if>` in a macro), not one inside another element (the
  /// `<joint name="...">` of a `<transmission>` names a joint, it does not make one).
  static const TiXmlElement* link_or_joint_made_by(const TiXmlElement* e) {
    for (const TiXmlElement* c = e->FirstChildElement(); c; c = c->NextSiblingElement()) {
      if (c->Value() == std::string("link") || c->Value() == std::string("joint")) return c;
      if (is_xacro(c))
        if (const TiXmlElement* found = link_or_joint_made_by(c)) return found;
    }
    return nullptr;
  }

  /// The first xacro element below `e` (depth first, in document order), or nullptr.
  static const TiXmlElement* first_xacro_below(const TiXmlElement* e) {
    for (const TiXmlElement* c = e->FirstChildElement(); c; c = c->NextSiblingElement()) {
      if (is_xacro(c)) return c;
      if (const TiXmlElement* found = first_xacro_below(c)) return found;
    }
    return nullptr;
  }

  [[noreturn]] void fail(int line, const std::string& message) const {
    throw ParseError(source_ + ":" + std::to_string(line) + ": " + message);
  }
  int link_line(const std::string& link) const { return links_.at(link).line; }
  const std::vector<JointInfo>& joints() const { return joints_; }
  const JointInfo& joint(const std::string& name) const { return joints_[joint_index_.at(name)]; }
  bool has_link(const std::string& name) const { return links_.count(name) > 0; }
  /// The capsules of a link's collision (or visual) elements; empty if none.
  const std::vector<Capsule>& capsules(const std::string& link, bool collision) const {
    static const std::vector<Capsule> kNone;
    const auto& map = collision ? collision_capsules_ : visual_capsules_;
    const auto found = map.find(link);
    return found == map.end() ? kNone : found->second;
  }
  /// " (did you mean 'x'?)" for a link name the file does not define.
  std::string closest_links(const std::string& name) const {
    std::vector<std::string> names;
    for (const auto& link : links_) names.push_back(link.first);
    return internal::did_you_mean(name, names);
  }
  const std::string& root() const { return root_; }

 private:
  static const char* attribute(const TiXmlElement* e, const char* name) { return e->Attribute(name); }

  std::string required(const TiXmlElement* e, const char* attr, const std::string& what) const {
    const char* v = e->Attribute(attr);
    if (v == nullptr || *v == '\0')
      fail(e->Row(), what + ": <" + e->Value() + "> lacks the attribute '" + attr + "'");
    return v;
  }

  /// required() for a name or a reference to one, which must not be an unexpanded xacro
  /// expression (`${prefix}hand` would otherwise become a link of that name).
  std::string name_attribute(const TiXmlElement* e, const char* attr, const std::string& what) const {
    std::string v = required(e, attr, what);
    if (v.find("${") != std::string::npos || v.find("$(") != std::string::npos)
      fail(e->Row(), what + ": <" + e->Value() + " " + attr + "> is '" + v +
                         "', an unexpanded xacro expression: expand the file with xacro first");
    return v;
  }

  std::vector<double> numbers(const TiXmlElement* e, const char* attr, size_t count,
                              const std::string& what) const {
    const std::string text = required(e, attr, what);
    // urdfdom reads a single number with the whole attribute's text: one followed by a space
    // is no number there (a mass of 0 kg, with a message that was set aside; a limit rejects
    // the file without a line). PNDbotics Adam Lite has <mass value="0.73234339 "/>.
    if (count == 1 && !text.empty() && std::isspace(static_cast<unsigned char>(text.back())))
      fail(e->Row(), what + ": <" + e->Value() + " " + attr + "> is '" + escaped_whitespace(text) +
                         "': urdfdom reads no number followed by a space there (it would take it as 0 or reject the "
                         "file); remove the space");
    // urdfdom splits a vector (xyz, rpy, size, rgba) at spaces only, so a tab or line break
    // stays inside a component, where it may lead but not trail the number ("0\t0 0" is one
    // component it cannot read). Split as it does, so that what passes here passes there.
    std::vector<std::string> tokens;
    if (count == 1) {
      std::istringstream in(text);
      for (std::string token; in >> token;) tokens.push_back(token);
    } else {
      for (size_t start = 0; start <= text.size();) {
        const size_t end = std::min(text.find(' ', start), text.size());
        if (end > start) tokens.push_back(text.substr(start, end - start));
        start = end + 1;
      }
    }
    std::vector<double> values;
    for (const std::string& token : tokens) {
      // As urdfdom reads numbers (a classic-locale stream that must use the whole token), so
      // that what passes here passes there: no hexadecimal, "inf", "nan" or "1,5".
      std::istringstream number(token);
      number.imbue(std::locale::classic());
      double v = 0.0;
      number >> v;
      const bool bad = number.fail() || !number.eof() || !std::isfinite(v);
      if (bad && std::any_of(token.begin(), token.end(), [](char c) { return std::isspace(static_cast<unsigned char>(c)); }))
        fail(e->Row(), what + ": <" + e->Value() + " " + attr + "> is '" + escaped_whitespace(text) +
                           "': urdfdom separates the numbers at spaces only (a tab or line break after a number "
                           "makes it unreadable there); separate them by spaces");
      if (bad)
        fail(e->Row(), what + ": <" + e->Value() + " " + attr + "> has '" + token +
                           "' where a finite number was expected" +
                           (token.find("${") != std::string::npos || token.find("$(") != std::string::npos
                                ? " (an unexpanded xacro expression: expand the file with xacro first)"
                                : ""));
      values.push_back(v);
    }
    if (values.size() != count)
      fail(e->Row(), what + ": <" + e->Value() + " " + attr + "> needs " + std::to_string(count) +
                         (count == 1 ? " number" : " numbers") + ", found " + std::to_string(values.size()));
    return values;
  }

  /// numbers() whose magnitudes are at most `largest` (kMaxLength, kMaxMass; infinity: any
  /// finite number), so that nothing computed from them overflows.
  std::vector<double> numbers_within(const TiXmlElement* e, const char* attr, size_t count, const std::string& what,
                                     double largest, const char* unit) const {
    std::vector<double> values = numbers(e, attr, count, what);
    for (const double v : values)
      if (std::abs(v) > largest) {
        std::ostringstream msg;
        msg << what << ": <" << e->Value() << " " << attr << "> has " << v << ", beyond the " << largest << " " << unit
            << " wbm accepts (a unit or exponent typo?)";
        fail(e->Row(), msg.str());
      }
    return values;
  }

  void check_link(const TiXmlElement* e) {
    const std::string name = name_attribute(e, "name", "link");
    const std::string what = "link " + quoted(name);
    if (links_.count(name))
      fail(e->Row(), "duplicate " + what + " (first defined on line " +
                         std::to_string(links_[name].line) + ")");
    links_[name] = {name, e->Row()};
    check_numeric_attributes(e, what);
    for (const char* kind : {"collision", "visual"})
      for (const TiXmlElement* c = e->FirstChildElement(kind); c; c = c->NextSiblingElement(kind)) {
        const TiXmlElement* geometry = c->FirstChildElement("geometry");
        const TiXmlElement* capsule = geometry ? geometry->FirstChildElement("capsule") : nullptr;
        if (capsule == nullptr || !capsule->Attribute("radius") || !capsule->Attribute("length")) continue;
        Capsule k;
        k.radius = numbers(capsule, "radius", 1, what)[0];  // finite: checked above
        k.length = numbers(capsule, "length", 1, what)[0];
        if (const TiXmlElement* origin = c->FirstChildElement("origin")) {
          if (origin->Attribute("xyz")) {
            const std::vector<double> p = numbers(origin, "xyz", 3, what);
            k.X_LG.p = Vector3(p[0], p[1], p[2]);
          }
          if (origin->Attribute("rpy")) {
            const std::vector<double> r = numbers(origin, "rpy", 3, what);
            k.X_LG.R = rotation_from_rpy(r[0], r[1], r[2]);
          }
        }
        (kind[0] == 'c' ? collision_capsules_ : visual_capsules_)[name].push_back(k);
      }
    if (const TiXmlElement* inertial = e->FirstChildElement("inertial")) {
      const TiXmlElement* mass = inertial->FirstChildElement("mass");
      if (mass == nullptr) fail(inertial->Row(), what + ": <inertial> lacks <mass>");
      const double m = numbers(mass, "value", 1, what)[0];  // finite and within kMaxMass: checked above
      if (m < 0.0) fail(mass->Row(), what + ": negative mass " + std::to_string(m) + " kg (expected >= 0)");
    }
  }

  /// Every number urdfdom reads below `e` (origins, axes, masses, inertias, limits,
  /// dynamics, safety controllers, calibrations, mimics, geometries, colours) is checked
  /// here first, so that a bad one is reported with its line: urdfdom's own message has none.
  /// Origins and masses also within kMaxLength and kMaxMass (prismatic limits: check_limits).
  void check_numeric_attributes(const TiXmlElement* e, const std::string& what) const {
    constexpr double kAny = std::numeric_limits<double>::infinity();
    struct Numeric {
      const char* element;
      const char* attribute;
      size_t count;
      double largest = kAny;
      const char* unit = "";
    };
    static const Numeric kNumeric[] = {
        {"origin", "xyz", 3, kMaxLength, "m"}, {"origin", "rpy", 3}, {"axis", "xyz", 3},
        {"mass", "value", 1, kMaxMass, "kg"}, {"inertia", "ixx", 1}, {"inertia", "ixy", 1}, {"inertia", "ixz", 1},
        {"inertia", "iyy", 1}, {"inertia", "iyz", 1}, {"inertia", "izz", 1}, {"limit", "lower", 1},
        {"limit", "upper", 1}, {"limit", "effort", 1}, {"limit", "velocity", 1}, {"dynamics", "damping", 1},
        {"dynamics", "friction", 1}, {"safety_controller", "soft_lower_limit", 1},
        {"safety_controller", "soft_upper_limit", 1}, {"safety_controller", "k_position", 1},
        {"safety_controller", "k_velocity", 1}, {"calibration", "rising", 1}, {"calibration", "falling", 1},
        {"mimic", "multiplier", 1}, {"mimic", "offset", 1}, {"box", "size", 3}, {"cylinder", "radius", 1},
        {"cylinder", "length", 1}, {"sphere", "radius", 1}, {"capsule", "radius", 1}, {"capsule", "length", 1},
        {"mesh", "scale", 3}, {"color", "rgba", 4}};
    for (const TiXmlElement* c = e->FirstChildElement(); c; c = c->NextSiblingElement()) {
      for (const Numeric& n : kNumeric)
        if (c->Value() == std::string(n.element) && c->Attribute(n.attribute) != nullptr)
          numbers_within(c, n.attribute, n.count, what, n.largest, n.unit);
      check_numeric_attributes(c, what);
    }
  }

  void check_joint(const TiXmlElement* e) {
    JointInfo j;
    j.name = name_attribute(e, "name", "joint");
    j.line = e->Row();
    const std::string what = "joint " + quoted(j.name);
    if (joint_index_.count(j.name))
      fail(j.line, "duplicate " + what + " (first defined on line " +
                       std::to_string(joints_[joint_index_[j.name]].line) + ")");
    check_numeric_attributes(e, what);
    j.type = required(e, "type", what);
    static const std::set<std::string> kTypes = {"revolute", "continuous", "prismatic", "fixed", "floating"};
    if (j.type == "planar") fail(j.line, what + ": planar joints are not supported");
    if (!kTypes.count(j.type))
      fail(j.line, what + ": unknown type " + quoted(j.type) +
                       " (expected revolute, continuous, prismatic, fixed or floating)");
    const TiXmlElement* parent = e->FirstChildElement("parent");
    const TiXmlElement* child = e->FirstChildElement("child");
    if (parent == nullptr) fail(j.line, what + " has no <parent link=...>");
    if (child == nullptr) fail(j.line, what + " has no <child link=...>");
    j.parent = name_attribute(parent, "link", what);
    j.child = name_attribute(child, "link", what);
    const bool movable = j.type == "revolute" || j.type == "continuous" || j.type == "prismatic";
    if (const TiXmlElement* mimic = e->FirstChildElement("mimic")) j.mimic = name_attribute(mimic, "joint", what);
    if (movable) {
      if (const TiXmlElement* axis = e->FirstChildElement("axis")) {
        const std::vector<double> a = numbers(axis, "xyz", 3, what);
        const double n = std::sqrt(a[0] * a[0] + a[1] * a[1] + a[2] * a[2]);
        if (n < 1e-12) fail(axis->Row(), what + ": joint axis is zero (expected a unit vector)");
        // Axes written with three or four digits (0.707 0 0.707: norm 0.99985) are meant to
        // be unit vectors and are normalised, as KDL and urdfdom users expect; a norm off by
        // more than 1 % is more likely a typo than rounding and is rejected.
        if (std::abs(n - 1.0) > kAxisNormTolerance) {
          std::ostringstream msg;
          msg << what << ": joint axis has norm " << n << " (expected a unit vector, within 1 %)";
          fail(axis->Row(), msg.str());
        }
      }
      check_limits(e, j, what);
    }
    // urdfdom rejects a <limit> without effort or velocity on any joint type (its message
    // has no line); wbm reads neither on fixed joints and keeps effort only for the export.
    if (const TiXmlElement* limit = e->FirstChildElement("limit"))
      for (const char* attribute : {"effort", "velocity"})
        if (limit->Attribute(attribute) == nullptr)
          fail(limit->Row(), what + ": <limit> lacks " + attribute + "=\"...\" (the URDF format requires it" +
                                 (std::string(attribute) == "effort" ? "; wbm only exports it)" : ")"));
    // Two more that urdfdom rejects without a line (wbm reads neither element).
    if (const TiXmlElement* safety = e->FirstChildElement("safety_controller"))
      if (safety->Attribute("k_velocity") == nullptr)
        fail(safety->Row(), what + ": <safety_controller> lacks k_velocity=\"...\" (the URDF format requires it; wbm "
                                   "does not use it)");
    if (const TiXmlElement* dynamics = e->FirstChildElement("dynamics"))
      if (dynamics->Attribute("damping") == nullptr && dynamics->Attribute("friction") == nullptr)
        fail(dynamics->Row(), what + ": <dynamics> has neither damping=\"...\" nor friction=\"...\" (the URDF format "
                                     "requires one; wbm uses neither)");
    joint_index_[j.name] = joints_.size();
    joints_.push_back(j);
  }

  /// A limit the joint lacks: an error at once, or with legs given recorded in `j` for the
  /// import to raise if the joint becomes a dof (parse_urdf).
  void missing_limit(JointInfo& j, int line, const std::string& message) const {
    if (options_.legs.empty()) fail(line, message);
    if (j.missing_limit.line == 0) j.missing_limit = {line, message};
  }

  void check_limits(const TiXmlElement* e, JointInfo& j, const std::string& what) const {
    const TiXmlElement* limit = e->FirstChildElement("limit");
    const bool bounded = j.type != "continuous";
    if (limit == nullptr) {
      // urdfdom rejects this one (without a line) even in a leg: an error at once.
      if (bounded && !options_.default_limits)
        fail(j.line, what + " (" + j.type + ") has no <limit>; add one or import with default limits (default_limits, --default-limits)");
      if (!bounded && j.mimic.empty() && !options_.default_limits)
        missing_limit(j, j.line, what + " (continuous) has no <limit velocity=...>; add one or import with default limits (default_limits, --default-limits)");
      return;
    }
    const double lower = limit->Attribute("lower") ? numbers(limit, "lower", 1, what)[0] : 0.0;
    const double upper = limit->Attribute("upper") ? numbers(limit, "upper", 1, what)[0] : 0.0;
    if (j.type == "prismatic") {
      numbers_within(limit, "lower", 1, what, kMaxLength, "m");
      numbers_within(limit, "upper", 1, what, kMaxLength, "m");
    }
    if (j.type == "revolute" && classify_revolute_limits(lower, upper) == RevoluteLimits::kOneSideUnlimited) {
      std::ostringstream msg;
      msg << what << ": limits [" << lower << ", " << upper << "] rad: one side is unlimited (beyond "
          << kUnlimitedRevolute << " rad), which wbm cannot represent; give both limits as angles, or both "
          << "beyond +-" << kUnlimitedRevolute << " rad (or type=\"continuous\") for no limit";
      fail(limit->Row(), msg.str());
    }
    if (bounded && lower > upper) {
      std::ostringstream msg;
      msg << what << ": lower limit " << lower << " is above upper limit " << upper;
      fail(limit->Row(), msg.str());
    }
    if (bounded && lower == upper && j.mimic.empty() && !options_.default_limits)
      missing_limit(j, limit->Row(), what + ": no position range (lower == upper); give lower < upper or import with default limits (default_limits, --default-limits)");
    const double velocity = limit->Attribute("velocity") ? numbers(limit, "velocity", 1, what)[0] : 0.0;
    if (velocity <= 0.0 && j.mimic.empty() && !options_.default_limits)
      missing_limit(j, limit->Row(), what + ": no speed limit (<limit velocity> must be > 0); add one or import with default limits (default_limits, --default-limits)");
  }

  void check_tree() {
    std::map<std::string, const JointInfo*> parent_joint;
    for (const JointInfo& j : joints_) {
      const std::string what = "joint " + quoted(j.name);
      if (!links_.count(j.parent)) fail(j.line, what + ": parent link " + quoted(j.parent) + " is not defined");
      if (!links_.count(j.child)) fail(j.line, what + ": child link " + quoted(j.child) + " is not defined");
      if (j.parent == j.child) fail(j.line, what + " connects link " + quoted(j.child) + " to itself (kinematic loop)");
      if (parent_joint.count(j.child)) {
        const JointInfo* other = parent_joint[j.child];
        fail(j.line, "kinematic loop: link " + quoted(j.child) + " is the child of " + what +
                         " and of joint " + quoted(other->name) + " (line " + std::to_string(other->line) + ")");
      }
      parent_joint[j.child] = &j;
    }
    for (const JointInfo& j : joints_)
      if (!j.mimic.empty() && !joint_index_.count(j.mimic))
        fail(j.line, "joint " + quoted(j.name) + " mimics joint " + quoted(j.mimic) + ", which is not defined");
    std::vector<std::string> roots;
    for (const auto& [name, link] : links_)
      if (!parent_joint.count(name)) roots.push_back(name);
    if (roots.empty()) fail(joints_.front().line, "kinematic loop: every link has a parent joint, there is no root link");
    if (roots.size() > 1) {
      std::string list;
      for (const std::string& r : roots) list += " " + quoted(r) + " (line " + std::to_string(links_[r].line) + ")";
      fail(links_[roots[1]].line, "the links do not form one tree; root links:" + list);
    }
    root_ = roots.front();
    // With one parent per link and one root, a link that does not reach the root through
    // its parents lies on a loop.
    for (const auto& [name, link] : links_) {
      std::string at = name;
      for (size_t steps = 0; at != root_; ++steps) {
        if (steps > links_.size()) {
          const JointInfo* j = parent_joint[name];
          fail(j->line, "kinematic loop through link " + quoted(name) + " and joint " + quoted(j->name));
        }
        at = parent_joint[at]->parent;
      }
    }
  }

  std::string source_;
  const UrdfImportOptions& options_;
  std::map<std::string, Located> links_;
  std::map<std::string, std::vector<Capsule>> collision_capsules_, visual_capsules_;
  std::vector<JointInfo> joints_;
  std::map<std::string, size_t> joint_index_;
  std::string root_;
};

Transform to_transform(const urdf::Pose& pose) {
  Transform X;
  X.p = {pose.position.x, pose.position.y, pose.position.z};
  X.R = Eigen::Quaterniond(pose.rotation.w, pose.rotation.x, pose.rotation.y, pose.rotation.z)
            .normalized()
            .toRotationMatrix();
  return X;
}

Vector3 to_vector(const urdf::Vector3& v) { return {v.x, v.y, v.z}; }

/// The lowest height [m] of a link's collision primitives (spheres, boxes, cylinders), or of
/// its visual ones where it has no collision element, in the frame where the link's pose is
/// X_RL, or +inf without any: a foot's sole lies below its link's origin (G1's 3.5 cm below
/// the ankle, H1's and Atlas's boxes). Visuals only without collisions: they may be markers
/// (EngineAI PM v2 draws a 2 cm sphere around its sole point, which stood it 2 cm high).
/// Meshes are left out (their files are not read), and so are primitives with a size that is
/// not finite or beyond kMaxLength (they say nothing of where the sole is). Capsules, which
/// urdfdom drops, come from the checker (`collision_capsules`, `visual_capsules`).
double lowest_primitive_z(const urdf::Link& link, const Transform& X_RL, const std::vector<Capsule>& collision_capsules,
                          const std::vector<Capsule>& visual_capsules) {
  double lowest = std::numeric_limits<double>::infinity();
  const auto add_capsule = [&](const Capsule& k) {  // a cylinder along z with hemispheres on its ends
    const Transform X_RG = X_RL * k.X_LG;
    const double depth = 0.5 * std::abs(X_RG.R(2, 2)) * k.length + k.radius;
    if (std::isfinite(depth) && depth >= 0.0 && depth <= kMaxLength) lowest = std::min(lowest, X_RG.p.z() - depth);
  };
  const auto add = [&](const urdf::Pose& origin, const urdf::GeometrySharedPtr& geometry) {
    if (!geometry) return;
    const Transform X_RG = X_RL * to_transform(origin);
    const auto row = X_RG.R.row(2);  // the geometry's axes' vertical components
    double depth = std::numeric_limits<double>::quiet_NaN();  // of its lowest point below its origin
    if (geometry->type == urdf::Geometry::SPHERE) {
      depth = static_cast<const urdf::Sphere&>(*geometry).radius;
    } else if (geometry->type == urdf::Geometry::BOX) {
      const urdf::Vector3& size = static_cast<const urdf::Box&>(*geometry).dim;
      depth = 0.5 * (std::abs(row(0)) * size.x + std::abs(row(1)) * size.y + std::abs(row(2)) * size.z);
    } else if (geometry->type == urdf::Geometry::CYLINDER) {  // along its z axis
      const auto& cylinder = static_cast<const urdf::Cylinder&>(*geometry);
      depth = 0.5 * std::abs(row(2)) * cylinder.length +
              cylinder.radius * std::sqrt(std::max(0.0, 1.0 - row(2) * row(2)));
    }
    if (std::isfinite(depth) && depth >= 0.0 && depth <= kMaxLength) lowest = std::min(lowest, X_RG.p.z() - depth);
  };
  for (const urdf::CollisionSharedPtr& collision : link.collision_array)
    if (collision) add(collision->origin, collision->geometry);
  for (const Capsule& k : collision_capsules) add_capsule(k);
  if (link.collision_array.empty() && collision_capsules.empty()) {
    for (const urdf::VisualSharedPtr& visual : link.visual_array)
      if (visual) add(visual->origin, visual->geometry);
    for (const Capsule& k : visual_capsules) add_capsule(k);
  }
  return lowest;
}

/// Inertial of a link, expressed in the frame of the body it is welded to (X_BL).
Inertial link_inertial(const urdf::Link& link, const Transform& X_BL) {
  Inertial in;
  if (!link.inertial) return in;
  const urdf::Inertial& u = *link.inertial;
  const Transform X_BI = X_BL * to_transform(u.origin);
  Matrix3 I;
  I << u.ixx, u.ixy, u.ixz, u.ixy, u.iyy, u.iyz, u.ixz, u.iyz, u.izz;
  in.mass = u.mass;
  in.com = X_BI.p;
  in.inertia = X_BI.R * I * X_BI.R.transpose();
  return in;
}

/// Adds b to a (both in the same body frame): combined mass, com and inertia about the
/// combined com (parallel-axis theorem).
void merge_inertial(Inertial& a, const Inertial& b) {
  const double m = a.mass + b.mass;
  if (m <= 0.0) return;
  const Vector3 c = (a.mass * a.com + b.mass * b.com) / m;
  auto shifted = [&c](const Inertial& in) {
    const Vector3 d = in.com - c;
    return Matrix3(in.inertia + in.mass * (d.squaredNorm() * Matrix3::Identity() - d * d.transpose()));
  };
  a.inertia = shifted(a) + shifted(b);
  a.com = c;
  a.mass = m;
}

Transform joint_motion(const urdf::Joint& j, double value) {
  Transform X;
  const Vector3 axis = to_vector(j.axis).normalized();
  if (j.type == urdf::Joint::PRISMATIC) {
    X.p = axis * value;
  } else if (j.type == urdf::Joint::REVOLUTE || j.type == urdf::Joint::CONTINUOUS) {
    X.R = Eigen::AngleAxisd(value, axis).toRotationMatrix();
  }
  return X;
}

/// A body to be created, before dofs are numbered. Index 0 is the root link.
struct BodySpec {
  Body body;
  const urdf::Joint* joint = nullptr;
};

/// Walks the URDF as an undirected tree from the chosen root, folding fixed joints and
/// locked legs into bodies and reversing joints that point towards the root.
class TreeBuilder {
 public:
  TreeBuilder(const urdf::ModelInterface& urdf, const UrdfChecker& checker, const UrdfImportOptions& options)
      : urdf_(urdf), checker_(checker), options_(options), legs_(options.legs.begin(), options.legs.end()) {
    for (const JointInfo& j : checker.joints()) {
      neighbours_[j.parent].push_back(&j);
      neighbours_[j.child].push_back(&j);
    }
  }

  /// @param R_UR the root link's orientation in the upper-body frame (root_rpy).
  void build(const std::string& root, const Matrix3& R_UR) {
    BodySpec spec;
    spec.body.name = root;
    specs_.push_back(spec);
    visit(root, 0, Transform::Identity(), Transform{R_UR, Vector3::Zero()}, nullptr, Mode::kNormal, "");
  }

  std::vector<BodySpec> specs_;
  std::vector<Frame> frames_;
  /// Frame (link or reversed joint's body) -> the frame it hangs from (Frame::parent).
  std::map<std::string, std::string> parent_of_;
  /// The legs' lowest point at zero joint values (a link's origin or the lowest point of its
  /// primitives, lowest_primitive_z) in the upper-body frame, and its link.
  double lowest_leg_z_ = std::numeric_limits<double>::infinity();
  std::string lowest_leg_link_;
  /// Height of each link's origin above the root link's in the upper-body frame, at zero
  /// joint values (dropped legs' links too).
  std::map<std::string, double> z_;
  /// The legs' length: the largest distance of a leg's link from its first link.
  double leg_length_ = 0.0;

  std::set<std::string> leg_links_;  ///< the links of the legs (locked or dropped)

  /// " (links welded to it higher up: a 0.68 m, b 0.5 m above the legs' lowest)", the links
  /// welded to the root link (up to three, the highest first) at least `clearance` [m] above
  /// the legs' lowest point at zero joint values (not the legs' own), or "": roots for a root
  /// link at the feet.
  std::string higher_root_links(double clearance) const {
    std::vector<std::pair<double, std::string>> links;
    for (const Frame& frame : frames_)
      if (frame.body == 0 && !leg_links_.count(frame.name) && z_.count(frame.name) &&
          z_.at(frame.name) - lowest_leg_z_ >= clearance)
        links.emplace_back(z_.at(frame.name) - lowest_leg_z_, frame.name);
    if (links.empty()) return "";
    std::sort(links.begin(), links.end(), [](const auto& a, const auto& b) { return a.first > b.first; });
    std::ostringstream text;
    text.precision(3);
    text << " (links welded to it higher up:";
    for (std::size_t k = 0; k < links.size() && k < 3; ++k)
      text << (k == 0 ? " " : ", ") << quoted(links[k].second) << " " << links[k].first << " m";
    text << " above the legs' lowest)";
    return text.str();
  }

 private:
  enum class Mode { kNormal, kLocked, kDropped };

  /// X_BL: pose of the link in its body; X_RL: pose of the link in the upper-body frame
  /// (the root link turned by root_rpy) at zero joint values (for the root height, also
  /// when legs hang below reversed joints). `parent`: the frame the link hangs from ("" for
  /// the root).
  void visit(const std::string& link_name, int body, const Transform& X_BL, const Transform& X_RL,
             const JointInfo* from, Mode mode, const std::string& parent) {
    const urdf::Link& link = *urdf_.links_.at(link_name);
    z_[link_name] = X_RL.p.z();
    if (mode != Mode::kDropped) {
      if (!parent.empty()) parent_of_[link_name] = parent;
      if (!(specs_[body].body.name == link_name && X_BL.p.isZero() && X_BL.R.isIdentity())) {
        Frame frame{link_name, body, X_BL};
        // Reached through a fixed joint or a locked leg's: that joint attaches the frame (a
        // reversed movable joint is its body's, named after the dof).
        if (from != nullptr && (mode != Mode::kNormal || urdf_.joints_.at(from->name)->type == urdf::Joint::FIXED))
          frame.joint_name = from->name;
        frames_.push_back(frame);
      }
      merge_inertial(specs_[body].body.inertial, link_inertial(link, X_BL));
    }
    if (mode != Mode::kNormal) {
      leg_links_.insert(link_name);
      leg_length_ = std::max(leg_length_, (X_RL.p - leg_origin_).norm());
      const double lowest = std::min(X_RL.p.z(), lowest_primitive_z(link, X_RL, checker_.capsules(link_name, true),
                                                                    checker_.capsules(link_name, false)));
      if (lowest < lowest_leg_z_) {
        lowest_leg_z_ = lowest;
        lowest_leg_link_ = link_name;
      }
    }
    for (const JointInfo* info : neighbours_.at(link_name)) {
      if (info == from) continue;
      const urdf::Joint& joint = *urdf_.joints_.at(info->name);
      const bool forward = info->parent == link_name;
      const std::string& other = forward ? info->child : info->parent;
      if (joint.type == urdf::Joint::FLOATING) {
        // A floating joint to a massless link without other joints is a world link: cut
        // here (the virtual dofs take its place). Anywhere else it would cut off part of
        // the robot without a word.
        const urdf::Link& far = *urdf_.links_.at(other);
        const bool world = (!far.inertial || far.inertial->mass == 0.0) && neighbours_.at(other).size() == 1;
        if (!world)
          checker_.fail(info->line, "joint " + quoted(info->name) + " (floating) leads to link " + quoted(other) +
                                        ", which is not a massless world link without other joints; floating "
                                        "joints are supported only there (the virtual dofs replace them)");
        continue;
      }
      Mode child_mode = mode;
      if (mode == Mode::kNormal && legs_.count(other))
        child_mode = options_.leg_mode == LegMode::kDrop ? Mode::kDropped : Mode::kLocked;
      else if (legs_.count(other))  // e.g. --legs r_hip,r_knee: the left leg would stay free
        checker_.fail(checker_.link_line(other), "leg link " + quoted(other) + " lies inside the leg of " +
                                                     quoted(leg_of_) + " (legs, --legs): name the first link of each leg");
      const Transform X_PC0 = to_transform(joint.parent_to_joint_origin_transform);
      // At joint value 0 (mimic joints at their offset).
      const Transform X_PC = X_PC0 * joint_motion(joint, joint.mimic ? joint.mimic->offset : 0.0);
      const Transform X_RO = X_RL * (forward ? X_PC : X_PC.inverse());
      if (joint.type == urdf::Joint::FIXED || child_mode != Mode::kNormal) {
        // Welded: fixed joint or locked leg at joint value 0.
        if (mode == Mode::kNormal && child_mode != Mode::kNormal) {
          leg_of_ = other;
          leg_origin_ = X_RO.p;
        }
        visit(other, body, X_BL * (forward ? X_PC : X_PC.inverse()), X_RO, info, child_mode, link_name);
        continue;
      }
      BodySpec spec;
      spec.joint = &joint;
      spec.body.joint_name = joint.name;
      spec.body.parent = body;
      spec.body.joint_type = joint.type == urdf::Joint::PRISMATIC ? JointType::kPrismatic : JointType::kRevolute;
      const Vector3 axis = to_vector(joint.axis).normalized();
      Transform X_BO;  // pose of the other link in the new body
      if (forward) {
        spec.body.name = other;
        spec.body.X_PJ = X_BL * X_PC0;
        spec.body.axis = axis;
      } else {
        // Reversed joint: X_CP = motion(a, q)^-1 * X_PC0^-1 = motion(-a, q) * X_PC0^-1. The new
        // body's frame is the child link's frame moved by motion(-a, q); q keeps its meaning.
        spec.body.name = checker_.has_link(joint.name) ? joint.name + "_reversed" : joint.name;
        spec.body.X_PJ = X_BL;
        spec.body.axis = -axis;
        X_BO = X_PC0.inverse();
      }
      specs_.push_back(spec);
      // The body's frame hangs from this link; the other link is that frame (forward) or hangs
      // from it (reversed: the body's frame is the joint's).
      parent_of_[spec.body.name] = link_name;
      visit(other, static_cast<int>(specs_.size()) - 1, X_BO, X_RO, info, Mode::kNormal,
            forward ? link_name : spec.body.name);
    }
  }

  const urdf::ModelInterface& urdf_;
  const UrdfChecker& checker_;
  const UrdfImportOptions& options_;
  std::set<std::string> legs_;
  std::string leg_of_;  // the leg link of the locked or dropped leg being visited
  Vector3 leg_origin_ = Vector3::Zero();  // where it is (upper-body frame, zero joint values)
  std::map<std::string, std::vector<const JointInfo*>> neighbours_;
};

Dof dof_from_joint(const urdf::Joint& joint, const UrdfChecker& checker, const UrdfImportOptions& options) {
  Dof dof;
  dof.name = joint.name;
  dof.type = joint.type == urdf::Joint::PRISMATIC ? JointType::kPrismatic : JointType::kRevolute;
  dof.continuous =
      joint.type == urdf::Joint::CONTINUOUS ||
      (joint.type == urdf::Joint::REVOLUTE && joint.limits &&
       classify_revolute_limits(joint.limits->lower, joint.limits->upper) == RevoluteLimits::kUnlimited);
  const bool prismatic = dof.type == JointType::kPrismatic;
  const double default_range = prismatic ? 1.0 : M_PI;
  const double default_speed = prismatic ? 0.5 : 2.0;
  if (joint.limits && joint.limits->lower < joint.limits->upper) {
    dof.lower = joint.limits->lower;
    dof.upper = joint.limits->upper;
  } else if (!dof.continuous) {
    if (!options.default_limits)
      checker.fail(checker.joint(joint.name).line, "joint " + quoted(joint.name) + " has no position range");
    dof.lower = -default_range;
    dof.upper = default_range;
  }
  dof.max_speed = joint.limits && joint.limits->velocity > 0.0 ? joint.limits->velocity : default_speed;
  dof.max_effort = joint.limits ? std::max(joint.limits->effort, 0.0) : 0.0;  // a negative effort means none
  return dof;
}

std::string root_link(const UrdfChecker& checker, const urdf::ModelInterface& urdf, const UrdfImportOptions& options,
                      const std::string& source) {
  if (!options.root.empty()) {
    if (!checker.has_link(options.root))
      throw ParseError(source + ": root link " + quoted(options.root) + " is not defined in the URDF" +
                       checker.closest_links(options.root));
    return options.root;
  }
  // A massless root link ("world") with a single fixed or floating joint is not a body.
  const urdf::Link& root = *urdf.links_.at(checker.root());
  if ((!root.inertial || root.inertial->mass == 0.0) && root.child_joints.size() == 1 &&
      (root.child_joints[0]->type == urdf::Joint::FIXED || root.child_joints[0]->type == urdf::Joint::FLOATING))
    return root.child_joints[0]->child_link_name;
  return checker.root();
}

/// An upper-body shift range of UrdfImportOptions, checked and written into its dof.
void set_upper_body_range(Dof& dof, const std::array<double, 2>& range, const std::string& option,
                          const std::string& source) {
  std::string flag = "--" + option;
  std::replace(flag.begin(), flag.end(), '_', '-');
  if (!(std::abs(range[0]) <= kMaxLength && std::abs(range[1]) <= kMaxLength && range[0] < range[1])) {
    std::ostringstream msg;
    msg << source << ": the upper body's shift range (" << option << ", " << flag
        << ") must be finite with lower < upper [m], got " << range[0] << ", " << range[1];
    throw ParseError(msg.str());
  }
  dof.lower = range[0];
  dof.upper = range[1];
}

/// The names of the virtual dofs and bodies wbm adds (heel_x, ..., upper_body_yaw) are not
/// available to the URDF's joints and links: a clash is an error naming the line (the model
/// builder would only say "duplicate").
void check_virtual_names(const UrdfChecker& checker, const TreeBuilder& tree, double height) {
  ModelBuilder probe("virtual base");
  add_virtual_base(probe, height, "\x01", Inertial{}, Inertial{});  // a name no XML file can hold
  const Model base = probe.build();
  std::set<std::string> dofs, bodies;
  for (const Dof& dof : base.dofs()) dofs.insert(dof.name);
  for (int b = 0; b + 1 < base.num_bodies(); ++b) bodies.insert(base.body(b).name);  // the last is the root link
  auto list = [](const std::set<std::string>& names) {
    std::string text;
    for (const std::string& name : names) text += (text.empty() ? "" : ", ") + name;
    return text;
  };
  for (const BodySpec& spec : tree.specs_)
    if (spec.joint && !spec.joint->mimic && dofs.count(spec.joint->name))
      checker.fail(checker.joint(spec.joint->name).line,
                   "joint " + quoted(spec.joint->name) + ": the name of one of the virtual dofs wbm adds (" + list(dofs) +
                       "); rename the joint");
  auto check_link = [&](const std::string& name) {
    if (bodies.count(name) && checker.has_link(name))
      checker.fail(checker.link_line(name), "link " + quoted(name) + ": the name of one of the virtual bodies wbm adds (" +
                                                list(bodies) + "); rename the link");
  };
  for (const BodySpec& spec : tree.specs_) check_link(spec.body.name);
  for (const Frame& frame : tree.frames_) check_link(frame.name);
}

/// Where the root link stands (UrdfImportOptions::root_height, upper_body_pivot; docs/model.md):
/// the root link origin's height above the ground [m] and the upper body's pivot above that
/// origin [m], given, measured from the legs, or taken from a cut-off root link.
/// @throws ParseError naming the option or the file's line.
struct RootPlacement {
  double height = 0.0, pivot = 0.0;
};
RootPlacement place_root(const UrdfChecker& checker, const TreeBuilder& tree, const urdf::ModelInterface& urdf,
                         const UrdfImportOptions& options, const std::string& root, const std::string& source) {
  double height = options.root_height;
  const bool has_legs = std::isfinite(tree.lowest_leg_z_);
  if (!std::isnan(height) && !std::isfinite(height)) {
    std::ostringstream msg;
    msg << source << ": the root height (root_height, --root-height) must be finite, got " << height;
    throw ParseError(msg.str());
  }
  // The upper body's pivot above the root link's origin: given, or the hips' height where the
  // root link's origin lies at the feet, or 0.
  double pivot = options.upper_body_pivot;
  const bool pivot_given = !std::isnan(pivot);
  if (pivot_given && !(std::isfinite(pivot) && pivot >= 0.0 && pivot <= 0.5 * kMaxLength)) {
    std::ostringstream msg;
    msg << source << ": the upper body's pivot above the root link (upper_body_pivot, --upper-body-pivot) must be "
        << "finite and >= 0 m, got " << pivot;
    throw ParseError(msg.str());
  }
  if (!pivot_given) {
    pivot = 0.0;
    // A root link whose origin lies at the feet (Surena V's and Berkeley Humanoid Lite's CAD
    // exports): the legs reach less than a tenth of their length below it, yet point down
    // from their first links by at least half of it. The virtual dofs then end at the hips'
    // height, so that the upper body crouches, leans and turns about its hips, not its soles.
    // Roots turned without root_rpy are not taken for it: their legs run sideways or up.
    // The feet must lie level with the root link's origin (within a tenth of the legs'
    // length): frames above the root given as legs (a camera, an IMU: legs of no length)
    // are not legs at the feet.
    if (has_legs && std::abs(tree.lowest_leg_z_) < 0.1 * tree.leg_length_) {
      double hips = -std::numeric_limits<double>::infinity();
      for (const std::string& leg : options.legs)
        if (const auto z = tree.z_.find(leg); z != tree.z_.end()) hips = std::max(hips, z->second);
      if (hips > 0.0 && hips - tree.lowest_leg_z_ >= 0.5 * tree.leg_length_) pivot = hips;
    }
  }
  // Given, the root height is the root link origin's, and the pivot must stand above the
  // ground with legs, on it or above without: a root at the feet may lie a little below its
  // soles (the export writes such a height with the pivot, and the import takes both back).
  if (!std::isnan(height) && (has_legs ? !(height + pivot > 0.0) : height + pivot < 0.0)) {
    std::ostringstream msg;
    msg << source << ": the root height (root_height, --root-height) must be "
        << (has_legs ? "> 0 m for a robot with legs (the upper body's pivot above the ground: root height + "
                       "upper_body_pivot > 0)"
                     : ">= 0 m (the upper body's pivot on the ground or above: root height + upper_body_pivot >= 0)")
        << ", got " << height;
    throw ParseError(msg.str());
  }
  if (std::isnan(height) && has_legs) {
    // Measured from the legs: they must point down from the pivot (the root link's origin
    // unless it lies at the feet), their lowest link (at zero joint values) at least a tenth
    // of the legs' length below it.
    // A root link turned upside down or on its side (root_rpy wrong or missing) leaves the
    // legs level with the root or above it; such a "height" of millimetres (Poppy's root
    // turned by roll 3.14159: 1.2e-8 m; by roll pi/2: 5 mm of its 0.39 m legs) was accepted
    // before, and the robot stood on its head. Only a tenth: legs may splay or fold (random
    // H1 variants: 0.57 m down with 2.0 m long legs), and a root turned by pitch pi/2 (legs
    // forward, 0.07 of 0.39 m down on Poppy) is not told from such a robot (`wbm model info`
    // notes legs that point more sideways than down: apps/model_notes.cpp).
    const double depth = pivot - tree.lowest_leg_z_;
    if (depth < 0.1 * tree.leg_length_) {
      std::ostringstream msg;
      msg << "leg link " << quoted(tree.lowest_leg_link_) << ", the legs' lowest at zero joint values, is ";
      if (depth > 0.0)
        msg << depth << " m below";
      else
        msg << "not below";
      msg << (pivot > 0.0 ? " the upper body's pivot" : " the root link's origin")
          << ", less than a tenth of the legs' length (" << tree.leg_length_
          << " m from a leg's first link to its farthest): the legs do not point down. If the root link's z axis is "
             "not up, give its orientation (root_rpy, --root-rpy); if its origin lies at the feet (as in some CAD "
             "exports), choose a link at the hips or above as the root (root, --root)"
          << tree.higher_root_links(0.1 * tree.leg_length_)
          << " or give the upper body's pivot above it (upper_body_pivot, --upper-body-pivot)"
          << "; if these are not the legs, name the first link of each (legs, --legs); or give the root height "
             "(root_height, --root-height)";
      checker.fail(checker.link_line(tree.lowest_leg_link_), msg.str());
    }
    // A pivot given far above the legs (5 m on G1) made a crouch range of metres, the legs
    // deep in the ground in the home pose: at most twice the legs' length above their lowest.
    if (depth > 2.0 * tree.leg_length_ && pivot_given) {
      std::ostringstream msg;
      msg << source << ": the upper body's pivot (upper_body_pivot, --upper-body-pivot, " << pivot
          << " m above the root link's origin) lies " << depth
          << " m above the legs' lowest point, more than twice the legs' length (" << tree.leg_length_
          << " m): the pivot is where the legs carry the upper body, at the hips or the pelvis";
      throw ParseError(msg.str());
    }
    height = -tree.lowest_leg_z_;  // the root link origin's: below the ground where it lies under the soles
  }
  // No legs and no height given: a massless root link cut off below the root (a fixed-base
  // robot's base_link or world on the ground, as Pepper's 0.33 m below its Tibia) is put on
  // the ground, where the file and ROS tools have it. So is a link that names the ground
  // ("world", or REP 120's "base_footprint"), at the root's origin or within a millimetre of
  // it (a dual-arm robot's world link at its base), or the root itself (a world link carrying
  // both arms' bases, as ABB's dual IRB120): height 0, so that the URDF's world frame is wbm's
  // (`wbm model info` notes a turn or a horizontal shift of the world link, which the upright
  // base does not keep). Not where the robot reaches below that link: a humanoid fixed to the
  // world at its pelvis (its legs below the "ground") keeps the default. Otherwise (REP 120's
  // massless base_link at a humanoid's pelvis, as NAO's and Romeo's without legs given; a
  // world link above the root) 1 m.
  // (A floating joint from the world link cuts the tree there: the link is not visited.)
  const auto cut = tree.z_.find(checker.root());
  const auto names_the_ground = [](const std::string& link) { return link == "world" || link == "base_footprint"; };
  // The tree's extent below and above a height z (link origins at zero joint values, relative
  // to the root's): a robot that reaches further below the "ground" than above it hangs from
  // it (G1 fixed at its pelvis: legs 0.76 m down, head 0.43 m up); arms that hang a little
  // below a pedestal's top at zero joint values do not make it so (RB-Y1's grippers, 0.19 m
  // down, its torso 0.66 m up).
  double lowest_link = 0.0, highest_link = 0.0;
  for (const auto& [link, z] : tree.z_)
    if (link != checker.root()) {
      lowest_link = std::min(lowest_link, z);
      highest_link = std::max(highest_link, z);
    }
  const auto stands_on = [&](double z) { return z - lowest_link <= std::max(highest_link - z, 1e-3); };
  if (std::isnan(height) && !has_legs) {
    // The default root, or the same link named (`--root base` where base is the default
    // already: the same robot, the same height). Another root given by name may lie anywhere
    // in the tree, its URDF root no cut-off link but a body above or below it.
    UrdfImportOptions by_default = options;
    by_default.root.clear();
    const bool default_root = root == root_link(checker, urdf, by_default, source);
    const bool cut_off = default_root && root != checker.root() && cut != tree.z_.end();
    if (cut_off && cut->second < -1e-3)
      height = -cut->second;
    else if (cut_off && names_the_ground(checker.root()) && cut->second < 1e-3 && stands_on(cut->second))
      height = std::max(0.0, -cut->second);
    else if (root == checker.root() && names_the_ground(root) && stands_on(0.0))
      height = 0.0;
  }
  if (std::isnan(height)) height = 1.0;
  if (has_legs && !(height + pivot > 0.0))  // legs of no length level with the pivot (longer ones: above)
    throw ParseError(source + ": the root height above the ground must be > 0 m (the legs' lowest link is not below the "
                              "root: give the root height explicitly, or, if the root link's z axis is not up, its "
                              "orientation with root_rpy, --root-rpy)");
  return {height, pivot};
}

}  // namespace

AddedFrame parse_added_frame(const std::string& text) {
  const std::string expected =
      "--add-frame '" + text + "': expected NAME:PARENT:X,Y,Z or NAME:PARENT:X,Y,Z:ROLL,PITCH,YAW (a new frame's name, a "
      "frame of the robot, the position in it in m, the orientation in rad)";
  std::vector<std::string> parts;
  std::stringstream in(text);
  for (std::string part; std::getline(in, part, ':');) parts.push_back(part);
  if (parts.size() < 3 || parts.size() > 4 || parts[0].empty() || parts[1].empty()) throw ConfigError(expected);
  const auto vector = [&](const std::string& numbers) {
    Vector3 v;
    std::stringstream values(numbers);
    std::string value;
    for (int k = 0; k < 3; ++k) {
      if (!std::getline(values, value, ',')) throw ConfigError(expected);
      std::size_t used = 0;
      try {
        v[k] = std::stod(value, &used);
      } catch (const std::exception&) {
        throw ConfigError(expected);
      }
      if (used != value.size() || !std::isfinite(v[k])) throw ConfigError(expected);
    }
    if (std::getline(values, value, ',')) throw ConfigError(expected);
    return v;
  };
  AddedFrame frame;
  frame.name = parts[0];
  frame.parent = parts[1];
  frame.xyz = vector(parts[2]);
  if (parts.size() == 4) frame.rpy = vector(parts[3]);
  return frame;
}

Model load_urdf(const std::string& path, const UrdfImportOptions& options) {
  struct stat status {};  // an ifstream opens a directory, which then reads as an empty document
  if (::stat(path.c_str(), &status) == 0 && S_ISDIR(status.st_mode))
    throw ParseError(path + ": is a directory, not a URDF file");
  std::ifstream in(path);
  if (!in) throw ParseError(path + ": cannot open the file");
  std::stringstream text;
  text << in.rdbuf();
  return parse_urdf(text.str(), options, path);
}

Model parse_urdf(const std::string& xml, const UrdfImportOptions& options, const std::string& source) {
  const UrdfChecker checker(xml, source, options);
  urdf::ModelInterfaceSharedPtr urdf;
  std::string urdfdom_message;
  {
    internal::ConsoleCapture capture;
    urdf = urdf::parseURDF(xml);
    urdfdom_message = capture.text();
  }
  if (!urdf) throw ParseError(source + ": urdfdom rejected the file: " + urdfdom_message);

  if (options.leg_mode == LegMode::kDrop && options.legs.empty())
    throw ParseError(source + ": dropping the legs (leg_mode kDrop, --drop-legs) needs the legs: name the first link of "
                              "each (legs, --legs)");
  for (size_t k = 0; k < options.legs.size(); ++k) {
    const std::string& leg = options.legs[k];
    if (!checker.has_link(leg))
      throw ParseError(source + ": leg link " + quoted(leg) + " is not defined in the URDF" + checker.closest_links(leg));
    // Named twice (a typo for the other leg): the other leg stayed free, the height came
    // from one leg, without a word.
    if (std::find(options.legs.begin(), options.legs.begin() + static_cast<std::ptrdiff_t>(k), leg) !=
        options.legs.begin() + static_cast<std::ptrdiff_t>(k))
      throw ParseError(source + ": leg link " + quoted(leg) + " is named twice (legs, --legs): name the first link of "
                                "each leg once");
  }
  const std::string root = root_link(checker, *urdf, options, source);
  for (const std::string& leg : options.legs)
    if (leg == root) throw ParseError(source + ": leg link " + quoted(leg) + " is the root link");

  const Vector3& rpy = options.root_rpy;
  if (!(rpy.array().abs() <= 2.0 * M_PI + 1e-6).all()) {  // a rounded 2 pi (6.283185) passes
    std::ostringstream msg;
    msg << source << ": the root link's roll, pitch, yaw (root_rpy, --root-rpy) must be finite and within [-2 pi, 2 pi] "
        << "rad, got " << rpy.x() << ", " << rpy.y() << ", " << rpy.z();
    if (rpy.allFinite()) msg << " (degrees?)";
    throw ParseError(msg.str());
  }
  const Matrix3 R_UR = rotation_from_rpy(rpy.x(), rpy.y(), rpy.z());
  TreeBuilder tree(*urdf, checker, options);
  tree.build(root, R_UR);
  const auto [height, pivot] = place_root(checker, tree, *urdf, options, root, source);
  check_virtual_names(checker, tree, height + pivot);
  std::array<Dof, 9> virtual_dofs = default_virtual_dofs(height + pivot);
  set_upper_body_range(virtual_dofs[3], options.upper_body_x_range, "upper_body_x_range", source);
  set_upper_body_range(virtual_dofs[4], options.upper_body_y_range, "upper_body_y_range", source);
  ModelBuilder builder(urdf->getName());
  const int ub = add_virtual_base(builder, virtual_dofs, root, Inertial{}, tree.specs_[0].body.inertial, R_UR, pivot);
  std::map<std::string, int> frame_index{{root, builder.num_frames() - 1}};  // the root body's, added last
  // Number the dofs in body order; mimic joints share their master's dof.
  std::map<std::string, int> dof_of_joint;
  for (const BodySpec& spec : tree.specs_)
    if (spec.joint && !spec.joint->mimic) {
      const auto& missing = checker.joint(spec.joint->name).missing_limit;
      if (missing.line != 0) checker.fail(missing.line, missing.message);
      dof_of_joint[spec.joint->name] = builder.add_dof(dof_from_joint(*spec.joint, checker, options));
    }
  for (size_t i = 1; i < tree.specs_.size(); ++i) {
    Body body = tree.specs_[i].body;
    const urdf::Joint& joint = *tree.specs_[i].joint;
    body.parent = body.parent == 0 ? ub : ub + body.parent;
    if (joint.mimic) {
      const auto master = dof_of_joint.find(joint.mimic->joint_name);
      if (master == dof_of_joint.end())
        checker.fail(checker.joint(joint.name).line,
                     "joint " + quoted(joint.name) + " mimics " + quoted(joint.mimic->joint_name) +
                         ", which is not a free joint of the imported body (locked, dropped, fixed or itself a mimic)");
      body.dof = master->second;
      body.multiplier = joint.mimic->multiplier;
      body.offset = joint.mimic->offset;
    } else {
      body.dof = dof_of_joint.at(joint.name);
    }
    builder.add_body(body);
    frame_index[body.name] = builder.num_frames() - 1;
  }
  std::map<std::string, Frame> placed;  // every frame's body and pose in it, for the added frames
  for (size_t i = 0; i < tree.specs_.size(); ++i)
    placed[tree.specs_[i].body.name] = Frame{tree.specs_[i].body.name, i == 0 ? ub : ub + static_cast<int>(i), {}};
  for (Frame frame : tree.frames_) {
    frame.body = frame.body == 0 ? ub : ub + frame.body;
    frame_index[frame.name] = builder.add_frame(frame);
    placed[frame.name] = frame;
  }
  for (const auto& [name, parent] : tree.parent_of_) builder.set_frame_parent(frame_index.at(name), frame_index.at(parent));
  for (const AddedFrame& added : options.added_frames) {
    const std::string what = source + ": added frame " + quoted(added.name) + " (added_frames, --add-frame): ";
    if (added.name.empty()) throw ParseError(source + ": added frame on " + quoted(added.parent) + ": the name is empty");
    if (frame_index.count(added.name)) throw ParseError(what + "the model already has a frame of that name");
    const auto parent = placed.find(added.parent);
    if (parent == placed.end()) {
      std::vector<std::string> names;
      for (const auto& entry : placed) names.push_back(entry.first);
      throw ParseError(what + "no frame named " + quoted(added.parent) +
                       (checker.has_link(added.parent) ? " (a link of a dropped leg)"
                                                       : internal::did_you_mean(added.parent, names)));
    }
    if (!added.xyz.allFinite() || !added.rpy.allFinite() || added.xyz.lpNorm<Eigen::Infinity>() > kMaxLength)
      throw ParseError(what + "its position and orientation must be finite (position within 1e6 m)");
    Frame frame{added.name, parent->second.body,
                parent->second.X_BF * Transform{rotation_from_rpy(added.rpy.x(), added.rpy.y(), added.rpy.z()), added.xyz}};
    frame_index[added.name] = builder.add_frame(frame);
    builder.set_frame_parent(frame_index[added.name], frame_index.at(added.parent));
    placed[added.name] = frame;
  }
  try {
    return builder.build();
  } catch (const ModelError& e) {
    throw ParseError(source + ": " + e.what());
  }
}

}  // namespace wbm
