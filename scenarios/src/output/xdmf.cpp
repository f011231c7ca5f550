// The XDMF sidecar (xdmf.hpp): where the centres sit in /q, and one grid per frame.
#include "output/xdmf.hpp"

#include <charconv>
#include <cstdio>
#include <optional>
#include <sstream>

namespace nonholo::scenarios {
namespace {

// The columns of the coordinates named `letter` followed by nothing or by a body number, in
// order: their first column, stride and count, when evenly spaced.
struct Columns {
  long first = -1, stride = 1, count = 0;
};

std::optional<Columns> columns_named(const std::vector<std::string>& names, const std::string& letter) {
  std::vector<long> found;
  for (std::size_t c = 0; c < names.size(); ++c) {
    const std::string& n = names[c];
    if (n.compare(0, letter.size(), letter) != 0) continue;
    const std::string rest = n.substr(letter.size());
    if (rest.find_first_not_of("0123456789") == std::string::npos) found.push_back(static_cast<long>(c));
  }
  if (found.empty()) return std::nullopt;
  Columns c{found[0], found.size() > 1 ? found[1] - found[0] : 1, static_cast<long>(found.size())};
  for (std::size_t i = 1; i < found.size(); ++i)
    if (found[i] - found[i - 1] != c.stride) return std::nullopt;
  return c;
}

std::string number(double x) {
  char buf[32];
  return std::string(buf, std::to_chars(buf, buf + sizeof buf, x).ptr);
}

// Frame k's entries of /q in these columns: a 1 x count hyperslab.
void slab(std::ostream& out, const std::string& source, std::size_t k, const Columns& c, const char* indent) {
  out << indent << "<DataItem ItemType=\"HyperSlab\" Dimensions=\"1 " << c.count << "\" Type=\"HyperSlab\">\n"
      << indent << "  <DataItem Dimensions=\"3 2\" Format=\"XML\">" << k << " " << c.first << " 1 " << c.stride
      << " 1 " << c.count << "</DataItem>\n"
      << indent << "  " << source << "\n"
      << indent << "</DataItem>\n";
}

}  // namespace

std::string xdmf_for(const std::string& h5_name, const std::vector<std::string>& coordinates,
                     const std::vector<double>& times, std::size_t max_frames) {
  const auto x = columns_named(coordinates, "x"), y = columns_named(coordinates, "y"),
             z = columns_named(coordinates, "z"), theta = columns_named(coordinates, "theta");
  if (!x || !y || x->count != y->count || (z && z->count != x->count) || times.empty()) return "";
  const std::size_t frames = times.size(), every = (frames + max_frames - 1) / max_frames;
  std::ostringstream q;
  q << "<DataItem Dimensions=\"" << frames << " " << coordinates.size()
    << "\" NumberType=\"Float\" Precision=\"8\" Format=\"HDF\">" << h5_name << ":/q</DataItem>";
  const std::string source = q.str();
  std::ostringstream out;
  out << "<?xml version=\"1.0\" ?>\n"
      << "<!-- nonholo: the bodies' centres in " << h5_name << " as a time series (ParaView: open this file) -->\n"
      << "<Xdmf Version=\"2.0\">\n <Domain>\n  <Grid Name=\"bodies\" GridType=\"Collection\" CollectionType=\"Temporal\">\n";
  std::vector<std::size_t> shown;  // every k-th frame and the last
  for (std::size_t k = 0; k < frames; k += every) shown.push_back(k);
  if (shown.back() != frames - 1) shown.push_back(frames - 1);
  for (const std::size_t k : shown) {
    out << "   <Grid Name=\"frame " << k << "\" GridType=\"Uniform\">\n"
        << "    <Time Value=\"" << number(times[k]) << "\"/>\n"
        << "    <Topology TopologyType=\"Polyvertex\" NumberOfElements=\"" << x->count << "\"/>\n"
        << "    <Geometry GeometryType=\"" << (z ? "X_Y_Z" : "X_Y") << "\">\n";
    slab(out, source, k, *x, "     ");
    slab(out, source, k, *y, "     ");
    if (z) slab(out, source, k, *z, "     ");
    out << "    </Geometry>\n";
    if (theta && theta->count == x->count) {
      out << "    <Attribute Name=\"theta\" AttributeType=\"Scalar\" Center=\"Node\">\n";
      slab(out, source, k, *theta, "     ");
      out << "    </Attribute>\n";
    }
    out << "   </Grid>\n";
  }
  out << "  </Grid>\n </Domain>\n</Xdmf>\n";
  return out.str();
}

}  // namespace nonholo::scenarios
