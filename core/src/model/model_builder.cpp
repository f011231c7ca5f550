// ModelBuilder (model_builder.hpp): bodies and their names, one-form rows, elements and callbacks, each
// checked as it is added, and build(), which checks the rows and finishes the Model.
#include <nonholo/model_builder.hpp>

#include <nonholo/sparse/big_buffer.hpp>

#include <Eigen/Eigenvalues>
#include <cmath>
#include <algorithm>
#include <cstdint>
#include <cstring>
#include <set>
#include <string_view>
#include <sstream>
#include <stdexcept>
#include <utility>

#include "model/builder_scales.hpp"
#include "model/element_set.hpp"
#include "model/structural_rank.hpp"

namespace nonholo {
namespace {

// Whether two chain bodies hold the same numbers bit for bit (-0.0 is not 0.0 here: the
// passes must compute exactly what each body's own entry would give).
bool same_bits(const detail::ChainBody& a, const detail::ChainBody& b) {
  const double x[] = {a.wx, a.wy, a.wt, a.a, a.d, a.f, a.k, a.kr, a.krr};
  const double y[] = {b.wx, b.wy, b.wt, b.a, b.d, b.f, b.k, b.kr, b.krr};
  return a.flags == b.flags && std::memcmp(x, y, sizeof x) == 0;
}

std::string describe_body(int index, const std::vector<std::string>& names) {
  std::ostringstream os;
  os << "body " << index << " (";
  for (std::size_t i = 0; i < names.size(); ++i) os << (i ? ", " : "") << names[i];
  os << ")";
  return os.str();
}

[[noreturn]] void fail(const std::string& message) { throw std::invalid_argument(message); }

// Refuses rows dependent by their pattern (structural_rank.hpp), naming the first few rows and
// columns: the whole list of 10^4 copies of a constraint would bury the message.
void check_structural_rank(const Model& model, const std::vector<int>& row_ptr, const std::vector<int>& col_idx) {
  const detail::StructuralDeficiency d =
      detail::structural_deficiency(model.num_one_forms(), model.mass().size(), row_ptr, col_idx);
  if (d.empty()) return;
  constexpr std::size_t kNamed = 4;
  std::ostringstream os;
  os << "dependent-one-forms: " << d.rows.size() << " one-form rows touch only the " << d.columns.size()
     << " velocity coordinates ";
  for (std::size_t i = 0; i < std::min(d.columns.size(), 2 * kNamed); ++i)
    os << (i ? ", " : "") << model.velocity_name(d.columns[i]);
  if (d.columns.size() > 2 * kNamed) os << " and " << d.columns.size() - 2 * kNamed << " more";
  os << ", so at most " << d.columns.size() << " of them can be independent at any configuration and "
     << d.rows.size() - d.columns.size() << " are redundant: ";
  for (std::size_t i = 0; i < std::min(d.rows.size(), kNamed); ++i)
    os << (i ? ", " : "") << model.describe_row(d.rows[i]);
  if (d.rows.size() > kNamed) os << " and " << d.rows.size() - kNamed << " more";
  os << "; remove the repeated or redundant constraints";
  fail(os.str());
}

}  // namespace

int ModelBuilder::add_body(const std::vector<std::string>& names, const Eigen::MatrixXd& block) {
  const int index = static_cast<int>(draft_.bodies_.size());
  const int k = static_cast<int>(names.size());
  auto who = [&] { return describe_body(index, names); };  // built only for a message
  if (k == 0) fail("body " + std::to_string(index) + " has no coordinates");
  if (block.rows() != k || block.cols() != k) {
    std::ostringstream os;
    os << who() << ": mass block is " << block.rows() << "x" << block.cols() << ", expected " << k
       << "x" << k << " (one row and column per coordinate)";
    fail(os.str());
  }
  check_names(index, names.data(), k);
  for (int i = 0; i < k; ++i)
    for (int j = 0; j < k; ++j)
      if (!std::isfinite(block(i, j))) {
        std::ostringstream os;
        os << who() << ": mass block entry (" << i << ", " << j << ") is " << block(i, j);
        fail(os.str());
      }
  for (int i = 0; i < k; ++i)
    if (!(block(i, i) > 0.0)) {
      std::ostringstream os;
      os << who() << ": mass block entry (" << i << ", " << i << ") for " << names[i] << " is "
         << block(i, i) << "; a mass or moment of inertia must be positive";
      fail(os.str());
    }
  const double scale = block.cwiseAbs().maxCoeff();
  for (int i = 0; i < k; ++i)
    for (int j = 0; j < i; ++j)
      if (std::abs(block(i, j) - block(j, i)) > 1e-12 * scale) {
        std::ostringstream os;
        os.precision(17);
        os << who() << ": mass block is not symmetric: M(" << i << ", " << j << ") = " << block(i, j)
           << " but M(" << j << ", " << i << ") = " << block(j, i);
        fail(os.str());
      }
  const Eigen::MatrixXd symmetric = 0.5 * (block + block.transpose());
  // A diagonal block's eigenvalues are its entries; skip the eigensolver (a million bodies).
  const bool diagonal = (block - Eigen::MatrixXd(block.diagonal().asDiagonal())).cwiseAbs().maxCoeff() == 0.0;
  Eigen::VectorXd eigenvalues = block.diagonal();
  if (!diagonal)
    eigenvalues = Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(symmetric, Eigen::EigenvaluesOnly).eigenvalues();
  const double smallest = eigenvalues.minCoeff(), largest = eigenvalues.maxCoeff();
  // Relative tests: the units of the entries mean nothing, their spread does. Solves with M
  // lose about log10(largest / smallest) of double precision's 16 digits.
  constexpr double kMaxCondition = 1e12;
  if (smallest < 0.0 && !(-smallest <= largest / kMaxCondition)) {
    std::ostringstream os;
    os << who() << ": mass block is not positive definite (smallest eigenvalue " << smallest << ")";
    fail(os.str());
  }
  if (smallest > 0.0) {
    const auto block_of = [&] { return who() + ": mass block"; };
    detail::check_mass_scale(block_of, "smallest eigenvalue", smallest);
    detail::check_mass_scale(block_of, "largest eigenvalue", largest);
  }
  if (!(smallest * kMaxCondition >= largest)) {
    std::ostringstream os;
    os << who() << ": mass block is too ill-conditioned for double precision: its eigenvalues run from "
       << smallest << " to " << largest;
    if (smallest > 0.0)  // the digits from logarithms: the ratio itself may overflow
      os << ", condition number " << largest / smallest << " (above " << kMaxCondition
         << "): solves with it would lose about " << std::lround(std::log10(largest) - std::log10(smallest))
         << " of double precision's 16 significant digits";
    else
      os << ", singular within round-off (a condition number of at most " << kMaxCondition << " is needed)";
    fail(os.str());
  }
  add_checked_body(names.data(), k, symmetric, BodyKind::General);
  return index;
}

void ModelBuilder::add_checked_body(const std::string* names, int k, const Eigen::Ref<const Eigen::MatrixXd>& block,
                                    BodyKind kind) {
  const int first = static_cast<int>(draft_.names_.size());
  draft_.bodies_.push_back({draft_.mass_.size(), k, first, k, kind, 0});
  draft_.names_.push_body(names, k);
  if (draft_.velocity_names_.size() > 0) draft_.velocity_names_.push_body(names, k);
  for (int i = 0; i < k; ++i) insert_name(first + i, names[i]);
  draft_.mass_.add_block(block);
  draft_.num_configuration_ += k;
}

void ModelBuilder::check_names(int index, const std::string* names, int k) const {
  auto who = [&] { return describe_body(index, std::vector<std::string>(names, names + k)); };
  for (int i = 0; i < k; ++i) {
    if (names[i].empty()) fail(who() + ": coordinate " + std::to_string(i) + " has an empty name");
    const int owner = find_name(names[i]);
    if (owner >= 0)
      fail("coordinate name '" + names[i] + "' is used by body " + std::to_string(body_of_coordinate(owner)) +
           " and by " + who());
    for (int j = 0; j < i; ++j)
      if (names[j] == names[i]) fail(who() + ": coordinate name '" + names[i] + "' appears twice");
  }
}

// A slot holds the name's hash in its high 32 bits and coordinate + 1 in its low 32 bits
// (0: empty): a probe compares hashes and reads a name only when they match, one cache miss
// per lookup instead of two.
namespace {
std::uint64_t name_hash(std::string_view name) { return std::hash<std::string_view>{}(name); }

// n of a name "<prefix><n>" (and the prefix's length), or -1 for a name kept in the hash table.
int name_number(std::string_view name, std::size_t& prefix) { return detail::NameStore::number_of(name, prefix); }
}  // namespace

int ModelBuilder::find_name(const std::string& name) const {
  std::size_t prefix = 0;
  if (const int n = name_number(name, prefix); n >= 0) {
    const auto it = numbered_of_.find(name.substr(0, prefix));
    if (it == numbered_of_.end()) return -1;
    const auto& pages = numbered_[static_cast<std::size_t>(it->second)].pages;
    const std::size_t page = static_cast<std::size_t>(n / kNamePage);
    return page < pages.size() && !pages[page].empty() ? pages[page][n % kNamePage] : -1;
  }
  if (name_slots_.empty()) return -1;
  const std::uint64_t hash = name_hash(name), tag = hash >> 32;
  const std::size_t mask = name_slots_.size() - 1;
  for (std::size_t at = hash & mask;; at = (at + 1) & mask) {
    const std::uint64_t slot = name_slots_[at];
    if (slot == 0) return -1;
    const int coordinate = static_cast<int>(slot & 0xffffffffu) - 1;
    if ((slot >> 32) == tag && draft_.names_[static_cast<std::size_t>(coordinate)] == name) return coordinate;
  }
}

void ModelBuilder::insert_name(int coordinate, const std::string& name) {
  std::size_t prefix = 0;
  if (const int n = name_number(name, prefix); n >= 0) {
    const auto added = numbered_of_.try_emplace(std::string(name.substr(0, prefix)), static_cast<int>(numbered_.size()));
    if (added.second) numbered_.emplace_back();
    auto& pages = numbered_[static_cast<std::size_t>(added.first->second)].pages;
    const std::size_t page = static_cast<std::size_t>(n / kNamePage);
    if (page >= pages.size()) pages.resize(page + 1);
    if (pages[page].empty()) pages[page].assign(kNamePage, -1);
    pages[page][n % kNamePage] = coordinate;
    return;
  }
  if (2 * (hashed_names_ + 1) > name_slots_.size()) {  // keep it at most half full
    std::vector<std::uint64_t> old(std::max<std::size_t>(64, 2 * name_slots_.size()), 0);
    old.swap(name_slots_);
    const std::size_t mask = name_slots_.size() - 1;
    for (std::uint64_t slot : old) {
      if (slot == 0) continue;
      const std::uint64_t hash = name_hash(draft_.names_[static_cast<std::size_t>(slot & 0xffffffffu) - 1]);
      std::size_t at = hash & mask;
      while (name_slots_[at] != 0) at = (at + 1) & mask;
      name_slots_[at] = slot;
    }
  }
  ++hashed_names_;
  const std::uint64_t hash = name_hash(name);
  const std::size_t mask = name_slots_.size() - 1;
  std::size_t at = hash & mask;
  while (name_slots_[at] != 0) at = (at + 1) & mask;
  name_slots_[at] = ((hash >> 32) << 32) | static_cast<std::uint64_t>(coordinate + 1);
}

int ModelBuilder::body_of_coordinate(int coordinate) const {
  const auto& bodies = draft_.bodies_;
  const auto it = std::upper_bound(bodies.begin(), bodies.end(), coordinate,
                                   [](int c, const Body& b) { return c < b.q_offset; });
  return static_cast<int>(it - bodies.begin()) - 1;
}

int ModelBuilder::add_planar_body(const std::array<std::string, 3>& names, double mass, double inertia) {
  auto who = [&] {
    return describe_body(static_cast<int>(draft_.bodies_.size()), std::vector<std::string>(names.begin(), names.end()));
  };
  auto check = [&](const char* what, double value) {
    if (!(value > 0.0) || !std::isfinite(value)) {
      std::ostringstream os;
      os << who() << ": " << what << " = " << value << " must be positive and finite";
      fail(os.str());
    }
  };
  check("mass m", mass);
  check("moment of inertia I", inertia);
  detail::check_mass_scale(who, "mass m", mass);
  detail::check_mass_scale(who, "moment of inertia I", inertia);
  const double smallest = std::min(mass, inertia), largest = std::max(mass, inertia);
  if (!(smallest * 1e12 >= largest))  // add_body says why
    return add_body({names.begin(), names.end()}, Eigen::Vector3d(mass, mass, inertia).asDiagonal().toDenseMatrix());
  // The common case without add_body's dynamic matrices (a million bodies).
  const int index = static_cast<int>(draft_.bodies_.size());
  check_names(index, names.data(), 3);
  const Eigen::Matrix3d block = Eigen::Vector3d(mass, mass, inertia).asDiagonal();
  add_checked_body(names.data(), 3, block, BodyKind::Planar);
  return index;
}

int ModelBuilder::add_rigid_body(const RigidBody& rb) {
  const int index = static_cast<int>(draft_.bodies_.size());
  const std::string suffix = rb.name.empty() ? std::to_string(index) : rb.name;
  auto who = [&] {
    return "rigid body " + std::to_string(index) + (rb.name.empty() ? "" : " ('" + rb.name + "')");
  };
  const int d = rb.translation;
  if (d != 0 && d != 2 && d != 3)
    fail(who() + ": translation = " + std::to_string(d) +
         " must be 0 (a fixed point), 2 (the centre moves in a horizontal plane) or 3 (free)");
  if (!(rb.mass > 0.0) || !std::isfinite(rb.mass)) {
    std::ostringstream os;
    os << who() << ": mass m = " << rb.mass << " must be positive and finite";
    fail(os.str());
  }
  const Eigen::Matrix3d& in = rb.inertia;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j)
      if (!std::isfinite(in(i, j))) {
        std::ostringstream os;
        os << who() << ": inertia entry (" << i << ", " << j << ") is " << in(i, j);
        fail(os.str());
      }
  const double scale = in.cwiseAbs().maxCoeff();
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < i; ++j)
      if (std::abs(in(i, j) - in(j, i)) > 1e-12 * scale) {
        std::ostringstream os;
        os.precision(17);
        os << who() << ": inertia is not symmetric: I(" << i << ", " << j << ") = " << in(i, j) << " but I(" << j
           << ", " << i << ") = " << in(j, i);
        fail(os.str());
      }
  const Eigen::Matrix3d inertia = 0.5 * (in + in.transpose());
  const Eigen::Vector3d moments = Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(inertia, Eigen::EigenvaluesOnly).eigenvalues();
  if (!(moments.minCoeff() > 0.0)) {
    std::ostringstream os;
    os << who() << ": inertia is not positive definite (principal moments " << moments.transpose() << ")";
    fail(os.str());
  }
  // A physical inertia: each principal moment at most the sum of the other two (equal for a
  // flat plate; 1e-10 of slack for a plate given turned, whose moments come from an eigensolver).
  if (!rb.any_inertia && moments[0] + moments[1] < moments[2] * (1.0 - 1e-10)) {
    std::ostringstream os;
    os << who() << ": principal moments " << moments[0] << ", " << moments[1] << ", " << moments[2]
       << " break the triangle inequality (" << moments[0] << " + " << moments[1] << " < " << moments[2]
       << "): no rigid body has them (I1 + I2 - I3 = 2 sum m z^2 >= 0), and the Moser-Veselov Lagrangian's "
          "J_d = tr(I)/2 - I is then indefinite; set RigidBody::any_inertia (scene parameter any_inertia=1, "
          "\"any_inertia\": true in a scene file) to use them on purpose";
    fail(os.str());
  }
  if (d > 0) detail::check_mass_scale(who, "mass m", rb.mass);
  const auto inertia_of = [&] { return who() + ": inertia"; };
  detail::check_mass_scale(inertia_of, "smallest principal moment", moments.minCoeff());
  detail::check_mass_scale(inertia_of, "largest principal moment", moments.maxCoeff());
  const double smallest = std::min(moments.minCoeff(), d > 0 ? rb.mass : moments.minCoeff());
  const double largest = std::max(moments.maxCoeff(), d > 0 ? rb.mass : moments.maxCoeff());
  if (!(smallest * 1e12 >= largest)) {
    std::ostringstream os;
    os << who() << ": mass block is too ill-conditioned for double precision: principal moments " << moments.transpose()
       << (d > 0 ? " and mass " + std::to_string(rb.mass) : std::string()) << " span a ratio of " << largest / smallest
       << " (above 1e12)";
    fail(os.str());
  }
  std::vector<std::string> qnames{"qw" + suffix, "qx" + suffix, "qy" + suffix, "qz" + suffix};
  std::vector<std::string> vnames{"wx" + suffix, "wy" + suffix, "wz" + suffix};
  const char* axes[3] = {"x", "y", "z"};
  for (int i = 0; i < d; ++i) {
    qnames.push_back(axes[i] + suffix);
    vnames.push_back(std::string("v") + axes[i] + suffix);
  }
  check_names(index, qnames.data(), 4 + d);

  Eigen::MatrixXd block = Eigen::MatrixXd::Zero(3 + d, 3 + d);
  block.topLeftCorner<3, 3>() = inertia;
  for (int i = 0; i < d; ++i) block(3 + i, 3 + i) = rb.mass;
  Model& m = draft_;
  if (m.velocity_names_.size() == 0)  // the bodies before (none rigid): the same names, body by body
    for (const Body& before : m.bodies_) {
      std::vector<std::string> same;
      for (int i = 0; i < before.size; ++i) same.push_back(m.names_[static_cast<std::size_t>(before.q_offset + i)]);
      m.velocity_names_.push_body(same.data(), before.size);
    }
  const int q_first = static_cast<int>(m.names_.size()), v_first = m.mass_.size();
  m.bodies_.push_back({v_first, 3 + d, q_first, 4 + d, BodyKind::Rigid, d});
  m.names_.push_body(qnames.data(), static_cast<int>(qnames.size()));
  m.velocity_names_.push_body(vnames.data(), static_cast<int>(vnames.size()));
  for (int i = 0; i < 4 + d; ++i) insert_name(q_first + i, qnames[static_cast<std::size_t>(i)]);
  m.mass_.add_block(block);
  m.num_configuration_ += 4 + d;
  RigidBlock r;
  r.body = index;
  r.q = q_first;
  r.v = v_first;
  r.translation = d;
  r.mass = rb.mass;
  r.inertia = inertia;
  // Inverted at unit scale: Eigen's 3x3 inverse goes through the determinant, the cube of the
  // moments, which under- or overflows from moments of about 1e-103 or 1e103 (a ball of mass and
  // inertia 1e-150 was refused as having radius of gyration 0, one of 1e160 with C = nan).
  const double unit = inertia.cwiseAbs().maxCoeff();
  r.inverse_inertia = (inertia / unit).inverse() / unit;
  r.inverse_inertia = (0.5 * (r.inverse_inertia + r.inverse_inertia.transpose())).eval();
  if (std::abs(std::ilogb(unit)) > 64) r.scale_exponent = std::ilogb(unit);
  r.isotropic = inertia(0, 1) == 0.0 && inertia(0, 2) == 0.0 && inertia(1, 2) == 0.0 && inertia(0, 0) == inertia(1, 1) &&
                inertia(1, 1) == inertia(2, 2);
  if (m.rigid_.empty() && reserved_bodies_ > index)  // reserve() counted this body and the ones after it
    sparse::reserve_buffer(m.rigid_, static_cast<std::size_t>(reserved_bodies_ - index));
  m.rigid_.push_back(r);
  return index;
}

void ModelBuilder::reserve(int bodies, int coordinates, int rows, int values) {
  if (bodies < 0 || coordinates < 0 || rows < 0 || values < 0) fail("reserve: negative size");
  using sparse::reserve_buffer;
  reserve_buffer(draft_.bodies_, static_cast<std::size_t>(bodies));
  draft_.mass_.reserve(coordinates);
  reserve_buffer(row_ptr_, static_cast<std::size_t>(rows) + 1);
  reserve_buffer(row_cols_, static_cast<std::size_t>(values));
  reserved_bodies_ = bodies;
  reserved_rows_ = rows;
}

int ModelBuilder::add_row(const int* columns, int count, std::string label) {
  row_cols_.insert(row_cols_.end(), columns, columns + count);
  row_ptr_.push_back(static_cast<int>(row_cols_.size()));
  const int row = num_rows() - 1;
  if (!label.empty() || draft_.row_labels_.size() > 0) {  // stays empty for unlabelled models
    while (draft_.row_labels_.size() < static_cast<std::size_t>(row)) draft_.row_labels_.push_text("");
    draft_.row_labels_.push_text(label);
  }
  return row;
}

int ModelBuilder::add_one_form(const std::vector<int>& columns, std::string label) {
  return add_row(columns.data(), static_cast<int>(columns.size()), std::move(label));
}

int ModelBuilder::add_holonomic_row(const std::vector<int>& columns, std::string label) {
  const int row = add_one_form(columns, std::move(label));
  draft_.holonomic_rows_.push_back(row);
  return row;
}

detail::ElementSet& ModelBuilder::elements() {
  if (!elements_) {  // room for the reserved rows: a knife edge per body and a hitch per two rows at most
    elements_ = std::make_shared<detail::ElementSet>();
    sparse::reserve_buffer(elements_->rows, static_cast<std::size_t>(reserved_rows_));
    sparse::reserve_buffer(elements_->knife_edges, static_cast<std::size_t>(std::min(reserved_bodies_, reserved_rows_)));
    sparse::reserve_buffer(elements_->hitches, static_cast<std::size_t>(std::min(reserved_bodies_, reserved_rows_ / 2)));
  }
  return *elements_;
}

int ModelBuilder::planar_body(int body, const char* element) const {
  const int count = static_cast<int>(draft_.bodies_.size());
  if (body < 0 || body >= count)
    fail(std::string(element) + ": body " + std::to_string(body) + " is out of range (the model has " +
         std::to_string(count) + " bodies so far; add the bodies first)");
  const Body& b = draft_.bodies_[body];
  if (b.kind == BodyKind::Rigid)
    fail(std::string(element) + ": body " + std::to_string(body) +
         " is a 3-D rigid body; this element acts on planar bodies (x, y, theta)");
  if (b.size != 3)
    fail(std::string(element) + ": body " + std::to_string(body) + " has " + std::to_string(b.size) +
         " coordinates; elements act on planar bodies (x, y, theta)");
  return b.offset;
}

const Body& ModelBuilder::rigid_body(int body, const char* element) const {
  const int count = static_cast<int>(draft_.bodies_.size());
  if (body < 0 || body >= count)
    fail(std::string(element) + ": body " + std::to_string(body) + " is out of range (the model has " +
         std::to_string(count) + " bodies so far; add the bodies first)");
  const Body& b = draft_.bodies_[body];
  if (b.kind != BodyKind::Rigid)
    fail(std::string(element) + ": body " + std::to_string(body) +
         " is not a 3-D rigid body (add it with add_rigid_body)");
  return b;
}

int ModelBuilder::centre_dimension(int body, const char* element) const {
  const int count = static_cast<int>(draft_.bodies_.size());
  if (body < 0 || body >= count)
    fail(std::string(element) + ": body " + std::to_string(body) + " is out of range (the model has " +
         std::to_string(count) + " bodies so far; add the bodies first)");
  const Body& b = draft_.bodies_[body];
  if (b.kind == BodyKind::Planar) return 2;
  if (b.kind == BodyKind::Rigid && b.translation >= 2) return b.translation;
  fail(std::string(element) + ": body " + std::to_string(body) +
       (b.kind == BodyKind::Rigid ? " is a rigid body with a fixed centre (translation 0)"
                                  : " is a general body (add_body): its centre is not known") +
       "; a rod joins the centres of planar bodies or of rigid bodies with translation 2 or 3");
}

namespace {
void check_finite(const char* element, const char* what, double value) {
  if (!std::isfinite(value)) {
    std::ostringstream os;
    os << element << ": " << what << " = " << value << " must be finite";
    fail(os.str());
  }
}
}  // namespace

// A length on a planar body whose velocity entries start at o (builder_scales.hpp).
void ModelBuilder::check_planar_arm(const Describe& who, const char* what, double length, int o) const {
  const sparse::BlockDiagonal& m = draft_.mass_;
  detail::check_lever_arm(who, what, length, 1.0 / std::min(m.entry(o, o), m.entry(o + 1, o + 1)),
                          1.0 / m.entry(o + 2, o + 2));
}

void ModelBuilder::check_rigid_arm(const Describe& who, int body, double radius) const {
  // rigid_ is in body order (a chain of a million balls: no linear search per element).
  const auto r = std::lower_bound(draft_.rigid_.begin(), draft_.rigid_.end(), body,
                                  [](const RigidBlock& x, int b) { return x.body < b; });
  detail::check_lever_arm(who, "radius", radius, 1.0 / r->mass, r->inverse_inertia.diagonal().maxCoeff());
}

int ModelBuilder::add_knife_edge(const KnifeEdge& knife, std::string label) {
  const int o = planar_body(knife.body, "knife edge");
  check_finite("knife edge", "a", knife.a);
  check_planar_arm([&knife] { return "knife edge on body " + std::to_string(knife.body); }, "offset a", knife.a, o);
  auto& set = elements();
  set.knife_edges.push_back(knife);
  set.rows.push_back({detail::ElementRow::Knife, static_cast<int>(set.knife_edges.size()) - 1});
  const int columns[3] = {o, o + 1, o + 2};
  return add_row(columns, 3, std::move(label));
}

int ModelBuilder::add_hitch(const Hitch& hitch, std::string label) {
  const int r = planar_body(hitch.rear, "hitch (rear body)"), f = planar_body(hitch.front, "hitch (front body)");
  if (hitch.rear == hitch.front) fail("hitch: joins body " + std::to_string(hitch.rear) + " to itself");
  check_finite("hitch", "d", hitch.d);
  check_finite("hitch", "f", hitch.f);
  const auto bodies = [&hitch] {
    return "hitch of bodies " + std::to_string(hitch.rear) + " and " + std::to_string(hitch.front);
  };
  check_planar_arm(bodies, "rear offset d (on the rear body)", hitch.d, r);
  check_planar_arm(bodies, "front offset f (on the front body)", hitch.f, f);
  auto& set = elements();
  set.hitches.push_back(hitch);
  const int index = static_cast<int>(set.hitches.size()) - 1;
  set.rows.push_back({detail::ElementRow::HitchX, index});
  set.rows.push_back({detail::ElementRow::HitchY, index});
  // "constraints[3] (hitch of bodies 0 and 1)" labels its rows "... 0 and 1, x)" and ", y)".
  const auto row_label = [&label](const char* axis) {
    if (label.empty()) return label;
    if (label.back() == ')') return label.substr(0, label.size() - 1) + ", " + axis + ")";
    return label + ", " + axis;
  };
  const int x[4] = {r, r + 2, f, f + 2}, y[4] = {r + 1, r + 2, f + 1, f + 2};
  const int first = add_row(x, 4, row_label("x"));
  draft_.holonomic_rows_.push_back(first);
  draft_.holonomic_rows_.push_back(add_row(y, 4, row_label("y")));
  return first;
}

void ModelBuilder::add_torsional_spring(const TorsionalSpring& spring) {
  planar_body(spring.first, "torsional spring");
  planar_body(spring.second, "torsional spring");
  if (spring.first == spring.second)
    fail("torsional spring: joins body " + std::to_string(spring.first) + " to itself");
  check_finite("torsional spring", "k", spring.k);
  check_finite("torsional spring", "rest", spring.rest);
  elements().springs.push_back(spring);
}

void ModelBuilder::add_thrust(Thrust thrust) {
  planar_body(thrust.body, "thrust");
  if (!thrust.force && !thrust.torque) fail("thrust on body " + std::to_string(thrust.body) + ": no force and no torque");
  elements().thrusts.push_back(std::move(thrust));
}

namespace {
void check_axis(const char* element, const Eigen::Vector3d& axis) {
  // Any finite nonzero axis (its length does not matter: the largest entry, not a norm that
  // could overflow or underflow).
  if (!std::isfinite(axis.x()) || !std::isfinite(axis.y()) || !std::isfinite(axis.z()) ||
      !(axis.cwiseAbs().maxCoeff() > 0.0)) {
    std::ostringstream os;
    os << element << ": axis (" << axis.transpose() << ") must be finite and nonzero";
    fail(os.str());
  }
}
void check_length(const char* element, const char* what, double value) {
  if (!(value > 0.0) || !std::isfinite(value)) {
    std::ostringstream os;
    os << element << ": " << what << " = " << value << " must be positive and finite";
    fail(os.str());
  }
}
// "constraints[3] (rolling ball on body 2)" labels its rows "... 2, x)", ", y)" and ", height)".
std::string part_label(const std::string& label, const char* part) {
  if (label.empty()) return label;
  if (label.back() == ')') return label.substr(0, label.size() - 1) + ", " + part + ")";
  return label + ", " + part;
}
}  // namespace

int ModelBuilder::add_body_axis_constraint(const BodyAxisConstraint& c, std::string label) {
  const Body& b = rigid_body(c.body, "body-axis constraint");
  check_axis("body-axis constraint", c.axis);
  auto& set = elements();
  set.body_axes.push_back({c.body, c.axis / c.axis.stableNorm()});  // a unit axis: the same constraint, C scaled
  set.rows.push_back({detail::ElementRow::BodyAxis, static_cast<int>(set.body_axes.size()) - 1});
  const int columns[3] = {b.offset, b.offset + 1, b.offset + 2};
  return add_row(columns, 3, std::move(label));
}

int ModelBuilder::add_space_axis_constraint(const SpaceAxisConstraint& c, std::string label) {
  const Body& b = rigid_body(c.body, "space-axis constraint");
  check_axis("space-axis constraint", c.axis);
  auto& set = elements();
  set.space_axes.push_back({c.body, c.axis / c.axis.stableNorm()});
  set.rows.push_back({detail::ElementRow::SpaceAxis, static_cast<int>(set.space_axes.size()) - 1});
  const int columns[3] = {b.offset, b.offset + 1, b.offset + 2};
  return add_row(columns, 3, std::move(label));
}

int ModelBuilder::add_rolling_ball(const RollingBall& ball, std::string label) {
  const Body& b = rigid_body(ball.body, "rolling ball");
  if (b.translation < 2)
    fail("rolling ball: body " + std::to_string(ball.body) +
         " has translation 0; a rolling ball's centre moves (translation 2 or 3)");
  check_length("rolling ball", "radius", ball.radius);
  check_rigid_arm([&ball] { return "rolling ball on body " + std::to_string(ball.body); }, ball.body, ball.radius);
  auto& set = elements();
  set.balls.push_back(ball);
  const int index = static_cast<int>(set.balls.size()) - 1;
  const int o = b.offset;
  const int x[4] = {o, o + 1, o + 2, o + 3}, y[4] = {o, o + 1, o + 2, o + 4};
  set.rows.push_back({detail::ElementRow::Ball, index, 0});
  const int first = add_row(x, 4, part_label(label, "x"));
  set.rows.push_back({detail::ElementRow::Ball, index, 1});
  add_row(y, 4, part_label(label, "y"));
  if (b.translation == 3) {
    set.rows.push_back({detail::ElementRow::Ball, index, 2});
    const int z[1] = {o + 5};
    draft_.holonomic_rows_.push_back(add_row(z, 1, part_label(label, "height")));
  }
  return first;
}

int ModelBuilder::add_rolling_disk(const RollingDisk& disk, std::string label) {
  const Body& b = rigid_body(disk.body, "rolling disk");
  if (b.translation != 3)
    fail("rolling disk: body " + std::to_string(disk.body) + " has translation " + std::to_string(b.translation) +
         "; a rolling disk's centre rises and falls as it tilts (translation 3)");
  check_length("rolling disk", "radius", disk.radius);
  check_rigid_arm([&disk] { return "rolling disk on body " + std::to_string(disk.body); }, disk.body, disk.radius);
  auto& set = elements();
  set.disks.push_back(disk);
  const int index = static_cast<int>(set.disks.size()) - 1;
  const int o = b.offset;
  const char* parts[3] = {"x", "y", "height"};
  int first = -1;
  for (int i = 0; i < 3; ++i) {
    set.rows.push_back({detail::ElementRow::Disk, index, static_cast<unsigned char>(i)});
    const int columns[4] = {o, o + 1, o + 2, o + 3 + i};
    const int row = add_row(columns, 4, part_label(label, parts[i]));
    if (i == 0) first = row;
    if (i == 2) draft_.holonomic_rows_.push_back(row);
  }
  return first;
}

int ModelBuilder::add_rod(const Rod& rod, std::string label) {
  const int d1 = centre_dimension(rod.first, "rod"), d2 = centre_dimension(rod.second, "rod");
  if (rod.first == rod.second) fail("rod: joins body " + std::to_string(rod.first) + " to itself");
  if (d1 != d2)
    fail("rod: body " + std::to_string(rod.first) + "'s centre moves in " + std::to_string(d1) + "-D, body " +
         std::to_string(rod.second) + "'s in " + std::to_string(d2) + "-D: a rod joins centres of the same dimension");
  check_length("rod", "length", rod.length);
  detail::check_rod_length("rod joining bodies " + std::to_string(rod.first) + " and " + std::to_string(rod.second),
                           rod.length);
  auto& set = elements();
  set.rods.push_back(rod);
  set.rows.push_back({detail::ElementRow::Rod, static_cast<int>(set.rods.size()) - 1});
  // Its columns are the two centres (a planar body's x, y; a rigid body's translation).
  const auto centre = [&](int body) {
    const Body& b = draft_.bodies_[body];
    return b.kind == BodyKind::Rigid ? b.offset + 3 : b.offset;
  };
  int columns[6];
  for (int i = 0; i < d1; ++i) {
    columns[i] = centre(rod.first) + i;
    columns[d1 + i] = centre(rod.second) + i;
  }
  const int row = add_row(columns, 2 * d1, std::move(label));
  draft_.holonomic_rows_.push_back(row);
  return row;
}

void ModelBuilder::add_gravity(double g) {
  if (!std::isfinite(g)) {
    std::ostringstream os;
    os << "gravity: g = " << g << " must be finite";
    fail(os.str());
  }
  auto& set = elements();
  if (set.has_gravity) fail("gravity: added twice (it acts on every rigid body with translation 3)");
  set.has_gravity = true;
  set.gravity = g;
}

void ModelBuilder::add_body_torque(BodyTorque torque) {
  rigid_body(torque.body, "body torque");
  if (!torque.torque) fail("body torque on body " + std::to_string(torque.body) + ": the function is empty");
  elements().torques.push_back(std::move(torque));
}

void ModelBuilder::add_body_force(BodyForce force) {
  const Body& b = rigid_body(force.body, "body force");
  if (b.translation == 0) fail("body force on body " + std::to_string(force.body) + ": its centre is fixed (translation 0)");
  if (!force.force) fail("body force on body " + std::to_string(force.body) + ": the function is empty");
  elements().body_forces.push_back(std::move(force));
}

namespace {

// The chain layout (element_set.hpp) from rows in body order, body by body: while every body
// but the last is alike (generated chains) only the common entry and the last are kept, never an
// entry per body (80 MB for a million bodies, written, compared and thrown away); all of them from
// the first body that differs. Springs, in any order, then need an entry per body for their sums
// (kept compact again if the bodies stay alike). False if the rows do not run body by body, a
// knife edge before its body's hitch, or a spring joins bodies that are not neighbours.
bool chain_layout(detail::ElementSet& set, const double* w, int bodies, std::string& why) {
  using detail::ChainBody;
  std::vector<ChainBody>& out = set.chain;
  out.clear();
  bool uniform = bodies >= 2;
  ChainBody first{}, last{};
  auto fresh = [w, bodies](int b) {
    return b < bodies ? ChainBody{w[3 * b], w[3 * b + 1], w[3 * b + 2], 0, 0, 0, 0, 0, 0, 0} : ChainBody{};
  };
  auto emit = [&](int b, const ChainBody& e) {  // bodies come in order 0, 1, ..., bodies - 1
    if (b == bodies - 1) {
      last = e;
    } else if (b == 0) {
      first = e;
    } else if (uniform && !same_bits(e, first)) {
      uniform = false;
      sparse::reserve_buffer(out, static_cast<std::size_t>(bodies));
      out.assign(static_cast<std::size_t>(b), first);
    }
    if (!uniform && b != bodies - 1) out.push_back(e);
  };
  int at = 0;  // the body whose rows come now; those before it are emitted
  ChainBody cur = fresh(0);
  auto move_to = [&](int b) {
    for (; at < b; cur = fresh(++at)) emit(at, cur);
  };
  for (const detail::ElementRow& row : set.rows) {
    if (row.kind == detail::ElementRow::Knife) {
      const KnifeEdge& e = set.knife_edges[row.element];
      if (e.body < at) {
        why = "the knife edge on body " + std::to_string(e.body) + " comes after rows of body " + std::to_string(at);
        return false;
      }
      move_to(e.body);
      if (cur.flags != 0) {
        why = "body " + std::to_string(e.body) + "'s knife edge comes after its hitch";
        return false;
      }
      cur.a = e.a;
      cur.flags |= detail::kChainKnife;
    } else if (row.kind == detail::ElementRow::HitchX) {
      const Hitch& h = set.hitches[row.element];
      if (h.front != h.rear + 1) {
        why = "the hitch with rear body " + std::to_string(h.rear) + " has front body " + std::to_string(h.front) +
              " (the fused step reads hitches from body b to body b + 1)";
        return false;
      }
      if (h.rear < at) {
        why = "the hitch from body " + std::to_string(h.rear) + " comes after rows of body " + std::to_string(at);
        return false;
      }
      move_to(h.rear);
      if (cur.flags & detail::kChainHitch) {
        why = "body " + std::to_string(h.rear) + " is the rear of two hitches";
        return false;
      }
      cur.d = h.d;
      cur.f = h.f;
      cur.flags |= detail::kChainHitch;
    }
  }
  move_to(bodies);
  if (uniform && set.springs.empty()) {
    out = {first, last};
  } else {
    if (uniform) {  // springs: an entry per body
      sparse::reserve_buffer(out, static_cast<std::size_t>(bodies));
      out.assign(static_cast<std::size_t>(bodies - 1), first);
    }
    out.push_back(last);
  }
  set.chain_uniform = uniform && set.springs.empty();
  set.chain_count = bodies;
  if (set.springs.empty()) return true;
  for (const TorsionalSpring& s : set.springs) {
    if (std::abs(s.first - s.second) != 1) {
      why = "a spring joins bodies " + std::to_string(s.first) + " and " + std::to_string(s.second) +
            ", which are not neighbours";
      return false;
    }
    // Written in D = theta_b - theta_{b+1}: a spring from b+1 to b has rest -r in it.
    const double rest = s.first < s.second ? s.rest : -s.rest;
    auto& cb = out[static_cast<std::size_t>(std::min(s.first, s.second))];
    cb.k += s.k;
    cb.kr += s.k * rest;
    cb.krr += s.k * rest * rest;
  }
  set.chain_uniform = bodies >= 2;
  for (int b = 1; set.chain_uniform && b + 1 < bodies; ++b) set.chain_uniform = same_bits(out[b], out[0]);
  if (set.chain_uniform) out = std::vector<ChainBody>{out.front(), out.back()};
  return true;
}

// Whether the elements make a chain in some order of bodies and rows: knife edges and hitches
// only, at most one knife edge a body, the hitches a path through every body (n - 1 of them,
// none on a body thrice, all connected), springs between hitched bodies. Such a model missed
// the fused step by its order alone (Model::performance_note says so).
bool chain_in_some_order(const detail::ElementSet& set, int bodies) {
  if (bodies < 3 || set.hitches.size() != static_cast<std::size_t>(bodies - 1)) return false;
  for (const detail::ElementRow& row : set.rows)
    if (row.kind != detail::ElementRow::Knife && row.kind != detail::ElementRow::HitchX &&
        row.kind != detail::ElementRow::HitchY)
      return false;
  const auto n = static_cast<std::size_t>(bodies);
  std::vector<int> degree(n, 0), knives(n, 0), parent(n);
  for (std::size_t b = 0; b < n; ++b) parent[b] = static_cast<int>(b);
  auto root = [&parent](int b) {  // union-find, halving the paths
    while (parent[static_cast<std::size_t>(b)] != b) {
      int& up = parent[static_cast<std::size_t>(b)];
      up = parent[static_cast<std::size_t>(up)];
      b = up;
    }
    return b;
  };
  for (const Hitch& h : set.hitches) {
    if (h.rear == h.front || ++degree[static_cast<std::size_t>(h.rear)] > 2 ||
        ++degree[static_cast<std::size_t>(h.front)] > 2)
      return false;
    const int a = root(h.rear), b = root(h.front);
    if (a == b) return false;  // a loop
    parent[static_cast<std::size_t>(a)] = b;
  }
  for (const KnifeEdge& e : set.knife_edges)
    if (++knives[static_cast<std::size_t>(e.body)] > 1) return false;
  if (!set.springs.empty()) {  // the hitched pairs, only then (a million-body chain's set-up)
    std::set<std::pair<int, int>> hitched;
    for (const Hitch& h : set.hitches) hitched.insert(std::minmax(h.rear, h.front));
    for (const TorsionalSpring& s : set.springs)
      if (!hitched.count(std::minmax(s.first, s.second))) return false;
  }
  return true;  // n - 1 hitches without a loop: a spanning tree, of degree at most 2: a path
}

// The common chain's rows, and a chain of knife edges alone, follow from the layout: when every
// row and its first value are those ElementSet::row() and value_start() give, the tables go.
void imply_rows(detail::ElementSet& set) {
  using Implied = detail::ElementSet::Implied;
  const Implied kind = set.hitched_chain ? Implied::Hitched : set.knife_chain ? Implied::Knives : Implied::None;
  if (kind == Implied::None) return;
  set.rows_implied = kind;
  set.implied_rows = set.rows.size();
  bool same = true;
  for (std::size_t r = 0; same && r < set.rows.size(); ++r) {
    const detail::ElementRow a = set.rows[r], b = set.row(r);
    same = a.kind == b.kind && a.part == b.part && a.element == b.element && set.value_offset[r] == set.value_start(r);
  }
  if (!same) {  // rows added in another order than the layout's
    set.rows_implied = Implied::None;
    return;
  }
  std::vector<detail::ElementRow>().swap(set.rows);
  std::vector<int>().swap(set.value_offset);
}

// Whether the rows are those of a ball chain (ElementSet::ball_chain), values and columns included.
bool ball_chain_layout(const detail::ElementSet& set, const Model& model, const sparse::RowPattern& pattern) {
  const int n = model.num_bodies();
  const auto& rigid = model.rigid_bodies();
  if (static_cast<int>(rigid.size()) != n || set.rows.size() != static_cast<std::size_t>(3 * n - 1)) return false;
  for (int b = 0; b < n; ++b) {
    const RigidBlock& r = rigid[static_cast<std::size_t>(b)];
    if (r.body != b || r.translation != 2 || r.v != 5 * b || r.q != 6 * b) return false;
  }
  using Row = detail::ElementRow;
  for (int b = 0; b < n; ++b) {
    const int r = 3 * b, o = 5 * b;
    const Row x = set.rows[static_cast<std::size_t>(r)], y = set.rows[static_cast<std::size_t>(r + 1)];
    if (x.kind != Row::Ball || x.part != 0 || y.kind != Row::Ball || y.part != 1 || x.element != b ||
        y.element != b || set.balls[static_cast<std::size_t>(b)].body != b)
      return false;
    const int expected[3][4] = {{o, o + 1, o + 2, o + 3}, {o, o + 1, o + 2, o + 4}, {o + 3, o + 4, o + 8, o + 9}};
    const int rows_here = b + 1 < n ? 3 : 2;
    if (b + 1 < n) {
      const Row rod = set.rows[static_cast<std::size_t>(r + 2)];
      if (rod.kind != Row::Rod || rod.element != b) return false;
      const Rod& e = set.rods[static_cast<std::size_t>(b)];
      if (e.first != b || e.second != b + 1) return false;
    }
    for (int j = 0; j < rows_here; ++j) {
      const int begin = pattern.row_ptr[static_cast<std::size_t>(r + j)];
      if (begin != 12 * b + 4 * j || pattern.row_ptr[static_cast<std::size_t>(r + j + 1)] != begin + 4) return false;
      for (int k = 0; k < 4; ++k)
        if (pattern.col_idx[static_cast<std::size_t>(begin + k)] != expected[j][k]) return false;
    }
  }
  return true;
}

// Model::rigid_only_translation: every body rigid, each one block of M^-1, one translation.
int rigid_only_translation(const Model& model) {
  const auto& rigid = model.rigid_bodies();
  const sparse::BlockDiagonal& minv = model.inverse_mass();
  if (rigid.empty() || static_cast<int>(rigid.size()) != model.num_bodies()) return -1;
  const int d = rigid.front().translation;
  for (const RigidBlock& r : rigid)
    if (r.translation != d ||
        (!minv.is_diagonal() && (minv.block_offset(r.body) != r.v || minv.block_size(r.body) != 3 + d)))
      return -1;
  return d;
}

}  // namespace

// Hands the elements' callbacks to the model and derives the chain layout (element_set.hpp).
void ModelBuilder::build_elements(Model& model, std::shared_ptr<detail::ElementSet> set) const {
  if (!set) return;
  const std::size_t element_rows = set->rows.size();
  const std::size_t rows = static_cast<std::size_t>(model.pattern_.rows);
  if (element_rows > 0 && element_rows != rows)
    fail("the model has " + std::to_string(element_rows) + " rows from elements (knife edges, hitches) and " +
         std::to_string(rows - element_rows) +
         " from add_one_form: give every row through elements, or every row through add_one_form with "
         "one_form_values");
  if (element_rows > 0 && (model.values_ || model.gap_ || model.bias_))
    fail("the model's rows come from elements (knife edges, hitches), which evaluate their own values, "
         "bias and gaps: do not also give one_form_values, one_form_bias or gap");
  if (!set->springs.empty() && model.potential_)
    fail("torsional springs make the model's potential: do not also give potential()");
  if ((!set->thrusts.empty() || set->has_rigid_forces()) && model.force_)
    fail("thrusts, body torques and forces and gravity make the model's external force: do not also give "
         "external_force()");
  const std::vector<RigidBlock>& rigid = model.rigid_bodies();
  if (set->has_gravity && std::none_of(rigid.begin(), rigid.end(),
                                       [](const RigidBlock& r) { return r.translation == 3; }))
    fail("gravity: no rigid body of the model moves in 3-D (translation 3): it would act on nothing");
  set->value_offset.assign(model.pattern_.row_ptr.begin(), model.pattern_.row_ptr.end() - 1);
  bool thirds = true;  // body b's velocity entries start at 3b: no array (ElementSet::v_offset)
  for (std::size_t b = 0; thirds && b < model.bodies_.size(); ++b) thirds = model.bodies_[b].offset == 3 * static_cast<int>(b);
  if (!thirds) {
    sparse::reserve_buffer(set->body_offset, model.bodies_.size());
    for (const Body& b : model.bodies_) set->body_offset.push_back(b.offset);
  }
  if (model.has_rigid_bodies()) {
    set->rigid = model.rigid_list_;
    set->rigid_of.assign(model.bodies_.size(), -1);
    for (std::size_t i = 0; i < rigid.size(); ++i) set->rigid_of[static_cast<std::size_t>(rigid[i].body)] = static_cast<int>(i);
    for (const Body& b : model.bodies_) set->body_q_offset.push_back(b.q_offset);
  }
  std::stable_sort(set->thrusts.begin(), set->thrusts.end(),
                   [](const Thrust& a, const Thrust& b) { return a.body < b.body; });

  // The chain layout: planar bodies in order, a diagonal M^-1, rows body by body.
  const int bodies = model.num_bodies();
  bool chain = model.inverse_mass_.is_diagonal() && !model.has_rigid_bodies();
  for (int b = 0; chain && b < bodies; ++b) chain = model.bodies_[b].size == 3 && model.bodies_[b].offset == 3 * b;
  for (std::size_t r = 0; chain && r < element_rows; ++r) chain = !set->rows[r].rigid();
  std::string why;
  if (chain) chain = chain_layout(*set, model.inverse_mass_.diagonal(), bodies, why);
  if (!chain && !why.empty() && chain_in_some_order(*set, bodies))
    model.performance_note_ =
        "the bodies, knife edges and hitches make a chain, but not in the order the fused chain step reads (" + why +
        "): the step takes the general path, 3 to 4 times slower per body-step; add body b's knife edge, then the "
        "hitch with rear body b and front body b + 1, body by body, numbering the bodies along the chain";
  if (!chain) {
    std::vector<detail::ChainBody>().swap(set->chain);
    set->chain_uniform = false;
    set->chain_count = 0;
  }
  if (chain) {
    const detail::ChainBodies body = set->chain_bodies();
    set->knife_chain = chain;
    for (int b = 0; set->knife_chain && b < bodies; ++b) set->knife_chain = body[b].flags == detail::kChainKnife;
    // Group b's rows all touch body b, and so does group b-1's hitch (its front): C couples
    // the two, and group b's last row reaches back to the first hitch row of group b-1.
    for (int b = 0, first = 0, hitch_before = -1; b < bodies; ++b) {
      const int flags = body[b].flags;
      const int count = ((flags & detail::kChainKnife) ? 1 : 0) + ((flags & detail::kChainHitch) ? 2 : 0);
      const int last = first + count - 1;
      if (count > 0) set->chain_bandwidth = std::max(set->chain_bandwidth, last - (hitch_before >= 0 ? hitch_before : first));
      hitch_before = (flags & detail::kChainHitch) ? last - 1 : -1;
      first += count;
    }
    set->hitched_chain = chain && bodies >= 3;  // two bodies have kd = 2: the generic sweeps
    for (int b = 0; set->hitched_chain && b < bodies; ++b)
      set->hitched_chain = body[b].flags == (b + 1 < bodies ? detail::kChainKnife | detail::kChainHitch
                                                            : detail::kChainKnife);
    imply_rows(*set);
  }
  if (!chain && element_rows > 0 && ball_chain_layout(*set, model, model.pattern_)) {
    set->ball_chain = true;
    set->chain_bandwidth = std::min(3, static_cast<int>(element_rows) - 1);
  }

  const std::shared_ptr<const detail::ElementSet> e = set;
  if (element_rows > 0) {
    model.values_ = [e](ConstVecRef q, VecRef mu) { e->values(q, mu); };
    model.bias_ = [e](ConstVecRef q, ConstVecRef v, VecRef out) { e->bias(q, v, out); };
    if (!model.holonomic_rows_.empty()) model.gap_ = [e](ConstVecRef q, VecRef g) { e->gap(q, g); };
  }
  if (!e->springs.empty()) {
    model.potential_ = [e](ConstVecRef q) { return e->potential(q); };
    model.gradient_ = [e](ConstVecRef q, VecRef g) { e->gradient(q, g); };
  }
  if (!e->thrusts.empty() || e->has_rigid_forces())
    model.force_ = [e](double t, ConstVecRef q, VecRef f) { e->force(t, q, f); };
  model.elements_ = e;
}

ModelBuilder& ModelBuilder::gap(ConstraintGap gap) {
  if (!gap) fail("gap: the function is empty");
  draft_.gap_ = std::move(gap);
  return *this;
}

ModelBuilder& ModelBuilder::one_form_values(OneFormValues values) {
  if (!values) fail("one_form_values: the value function is empty");
  draft_.values_ = std::move(values);
  return *this;
}

ModelBuilder& ModelBuilder::one_form_bias(OneFormBias bias) {
  draft_.bias_ = std::move(bias);
  return *this;
}

ModelBuilder& ModelBuilder::potential(Potential value, PotentialGradient gradient) {
  if (static_cast<bool>(value) != static_cast<bool>(gradient))
    fail("potential: give both the value and its gradient, or neither");
  draft_.potential_ = std::move(value);
  draft_.gradient_ = std::move(gradient);
  return *this;
}

ModelBuilder& ModelBuilder::external_force(ExternalForce force) {
  draft_.force_ = std::move(force);
  return *this;
}

ModelBuilder& ModelBuilder::momentum_map(const std::string& name, MomentumMap map) {
  if (name.empty()) fail("momentum_map: the name is empty");
  if (!map) fail("momentum_map '" + name + "': the function is empty");
  if (!map_names_.insert(name).second) fail("momentum_map '" + name + "' is defined twice");
  draft_.momentum_maps_.push_back({name, std::move(map), {}});
  return *this;
}

ModelBuilder::VelocityRange ModelBuilder::velocities_of(int body) const {
  if (body < 0 || body >= static_cast<int>(draft_.bodies_.size()))
    fail("body " + std::to_string(body) + " does not exist (the model has " + std::to_string(draft_.bodies_.size()) +
         " bodies so far)");
  const Body& b = draft_.bodies_[static_cast<std::size_t>(body)];
  return {b.offset, b.size};
}

ModelBuilder& ModelBuilder::symmetry(const std::string& name, SymmetryGenerator generator, MomentumMap value,
                                     int body) {
  if (!generator) fail("symmetry '" + name + "': the generator is empty");
  if (body < -1 || body >= static_cast<int>(draft_.bodies_.size()))
    fail("symmetry '" + name + "': body " + std::to_string(body) + " does not exist (the model has " +
         std::to_string(draft_.bodies_.size()) + " bodies so far; -1: not local to one body)");
  if (value) {
    momentum_map(name, std::move(value));
    draft_.momentum_maps_.back().generator = std::move(generator);
    draft_.momentum_maps_.back().body = body;
    return *this;
  }
  // J = <xi(q), p>, xi evaluated into a buffer on the stack (up to kStack velocities: no heap
  // at all), else into one of the calling thread's (allocated at its first use, and when a
  // larger model's map is evaluated on that thread). Restarts read the generator directly.
  // A local generator writes its body's entries only: J is their product with p's.
  const int first = body >= 0 ? draft_.bodies_[static_cast<std::size_t>(body)].offset : 0;
  const int size = body >= 0 ? draft_.bodies_[static_cast<std::size_t>(body)].size : -1;
  MomentumMap map = [generator, first, size](ConstVecRef q, ConstVecRef p) {
    constexpr int kStack = 256;
    const Eigen::Index count = size < 0 ? p.size() : size;
    if (p.size() <= kStack) {
      Eigen::Matrix<double, Eigen::Dynamic, 1, 0, kStack, 1> xi(p.size());
      generator(q, xi);
      return size < 0 ? xi.dot(p) : xi.segment(first, count).dot(p.segment(first, count));
    }
    thread_local Vector xi;
    if (xi.size() < p.size()) xi.resize(p.size());
    generator(q, xi.head(p.size()));
    return size < 0 ? xi.head(p.size()).dot(p) : xi.segment(first, count).dot(p.segment(first, count));
  };
  momentum_map(name, std::move(map));
  draft_.momentum_maps_.back().generator = std::move(generator);
  draft_.momentum_maps_.back().body = body;
  return *this;
}

ModelBuilder& ModelBuilder::configuration_metric(MetricValue value, MetricDerivative derivative) {
  if (!value || !derivative) fail("configuration_metric: give both the metric and its derivative");
  draft_.metric_ = std::move(value);
  draft_.metric_derivative_ = std::move(derivative);
  return *this;
}

Model ModelBuilder::build() const& {
  Model draft = draft_;
  draft.pattern_.row_ptr = row_ptr_;
  draft.pattern_.col_idx = row_cols_;
  return finish(std::move(draft), elements_ ? std::make_shared<detail::ElementSet>(*elements_) : nullptr);
}

Model ModelBuilder::build() && {
  Model draft = std::move(draft_);
  draft.pattern_.row_ptr = std::move(row_ptr_);
  draft.pattern_.col_idx = std::move(row_cols_);
  std::shared_ptr<detail::ElementSet> elements = std::move(elements_);
  *this = ModelBuilder();  // left empty and usable
  return finish(std::move(draft), std::move(elements));
}

namespace {
// Rows of mu that touch one body all couple in C through its velocities: a dense block. From
// this many, its factorisation (rows^3 / 3 operations, every step) is worth a word to the user
// (256 rows: 5.6e6; a star of 800 hitches, 1600 rows: 1.4e9, measured 2-5 s a step).
constexpr int kDenseBlockRows = 256;
}  // namespace

// Model::performance_note for a body touched by kDenseBlockRows rows or more: O(nnz + n), once.
void ModelBuilder::note_dense_block(Model& model) {
  const sparse::RowPattern& pattern = model.pattern_;
  if (pattern.rows < kDenseBlockRows) return;
  std::vector<int> body_of(static_cast<std::size_t>(pattern.cols), 0);
  for (int b = 0; b < model.num_bodies(); ++b)
    for (int i = 0; i < model.bodies_[b].size; ++i) body_of[static_cast<std::size_t>(model.bodies_[b].offset + i)] = b;
  std::vector<int> rows_on(static_cast<std::size_t>(model.num_bodies()), 0), last_row(rows_on.size(), -1);
  for (int r = 0; r < pattern.rows; ++r)
    for (int k = pattern.row_ptr[r]; k < pattern.row_ptr[r + 1]; ++k) {
      const auto b = static_cast<std::size_t>(body_of[static_cast<std::size_t>(pattern.col_idx[k])]);
      if (last_row[b] != r) ++rows_on[b], last_row[b] = r;  // a row counts once for a body
    }
  const auto most = std::max_element(rows_on.begin(), rows_on.end());
  if (*most < kDenseBlockRows) return;
  const double rows = *most;
  std::ostringstream os;
  os.precision(2);
  os << "body " << (most - rows_on.begin()) << " is touched by " << *most
     << " constraint rows (a hub hitched to many bodies, say): through its velocities they all couple in "
        "C = mu M^-1 mu^T, a dense "
     << *most << " x " << *most << " block whose factorisation costs about " << rows * rows * rows / 3.0
     << " floating-point operations every step, growing as the cube of the rows (800 hitches on one body: 2-5 s a "
        "step measured on a 2-core AMD EPYC); such a model is correct but slow to step";
  if (!model.performance_note_.empty()) model.performance_note_ += "; ";
  model.performance_note_ += os.str();
}

Model ModelBuilder::finish(Model model, std::shared_ptr<detail::ElementSet> elements) const {
  if (model.bodies_.empty()) fail("the model has no bodies");
  if (!model.rigid_.empty()) {  // one list for the model, its copies and its elements
    model.rigid_list_ = std::make_shared<const std::vector<RigidBlock>>(std::move(model.rigid_));
    std::vector<RigidBlock>().swap(model.rigid_);
  }
  if (model.has_rigid_bodies() && model.metric_)
    fail("a configuration-dependent metric (configuration_metric) and 3-D rigid bodies cannot be combined: the "
         "implicit general form integrates planar coordinates only");
  const int n = model.mass_.size();  // columns are velocity entries
  const int rows = static_cast<int>(model.pattern_.row_ptr.size()) - 1;
  model.inverse_mass_ = model.mass_.inverse();
  model.rigid_only_translation_ = rigid_only_translation(model);

  model.pattern_.rows = rows;
  model.pattern_.cols = n;
  std::vector<int> sorted;
  const auto& ptr = model.pattern_.row_ptr;
  const auto& cols = model.pattern_.col_idx;
  for (int r = 0; r < rows; ++r) {
    auto row = [&] { return model.describe_row(r); };  // built only for a message
    if (ptr[r + 1] == ptr[r]) fail(row() + " has no columns (an empty row constrains nothing)");
    for (int k = ptr[r]; k < ptr[r + 1]; ++k) {
      const int c = cols[k];
      if (c < 0 || c >= n) {
        std::ostringstream os;
        os << row() << ": column " << c << " is out of range (the model has " << n
           << (model.has_rigid_bodies() ? " velocity coordinates" : " coordinates") << ", columns 0 to " << n - 1
           << ")";
        fail(os.str());
      }
    }
    int twice = -1;
    if (ptr[r + 1] - ptr[r] <= 16) {  // an element's row: pairs, no copy; the smallest repeat, as sorted
      for (int k = ptr[r] + 1; k < ptr[r + 1]; ++k)
        for (int j = ptr[r]; j < k; ++j)
          if (cols[j] == cols[k] && (twice < 0 || cols[k] < twice)) twice = cols[k];
    } else {
      sorted.assign(cols.begin() + ptr[r], cols.begin() + ptr[r + 1]);
      std::sort(sorted.begin(), sorted.end());
      const auto at = std::adjacent_find(sorted.begin(), sorted.end());
      if (at != sorted.end()) twice = *at;
    }
    if (twice >= 0)
      fail(row() + ": column " + std::to_string(twice) + " (" + std::string(model.velocity_name(twice)) +
           ") appears twice");
  }
  check_structural_rank(model, ptr, cols);  // before anything the size of C is built
  build_elements(model, std::move(elements));
  if (rows > 0 && !model.values_)
    fail("the model has " + std::to_string(rows) +
         " one-form rows but no value function (call one_form_values)");
  if (!model.holonomic_rows_.empty() && !model.gap_)
    fail("the model has " + std::to_string(model.holonomic_rows_.size()) +
         " holonomic rows but no gap function (call gap)");
  if (model.holonomic_rows_.empty() && model.gap_)
    fail("a gap function was given but no holonomic rows (add them with add_holonomic_row)");
  if (!model.is_chain() && !(model.elements_ && model.elements_->ball_chain)) note_dense_block(model);
  model.new_gram();
  model.new_name_list();
  return model;
}

}  // namespace nonholo
