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

// Whether XML 1.0 can hold the text: valid UTF-8 of characters it allows (no control character
// but tab, newline and carriage return; no surrogates, U+FFFE or U+FFFF).
bool xml_can_hold(const std::string& s) {
  for (std::size_t i = 0; i < s.size();) {
    const auto c = static_cast<unsigned char>(s[i]);
    int extra = 0;
    unsigned long cp = c;
    if (c < 0x80) {
      if (c < 0x20 && c != '\t' && c != '\n' && c != '\r') return false;
    } else if ((c & 0xE0) == 0xC0) {
      extra = 1, cp = c & 0x1F;
    } else if ((c & 0xF0) == 0xE0) {
      extra = 2, cp = c & 0x0F;
    } else if ((c & 0xF8) == 0xF0) {
      extra = 3, cp = c & 0x07;
    } else {
      return false;
    }
    if (i + static_cast<std::size_t>(extra) >= s.size() && extra > 0) return false;  // cut short
    for (int k = 1; k <= extra; ++k) {
      const auto d = static_cast<unsigned char>(s[i + static_cast<std::size_t>(k)]);
      if ((d & 0xC0) != 0x80) return false;
      cp = (cp << 6) | (d & 0x3F);
    }
    const unsigned long least[] = {0, 0x80, 0x800, 0x10000};
    if (cp < least[extra] || cp > 0x10FFFF || (cp >= 0xD800 && cp <= 0xDFFF) || cp == 0xFFFE || cp == 0xFFFF)
      return false;
    i += 1 + static_cast<std::size_t>(extra);
  }
  return true;
}

// The text as XML character data: &, < and > as entities.
std::string xml_text(const std::string& s) {
  std::string out;
  for (const char c : s) {
    if (c == '&')
      out += "&amp;";
    else if (c == '<')
      out += "&lt;";
    else if (c == '>')
      out += "&gt;";
    else
      out += c;
  }
  return out;
}

// The text inside an XML comment, which may not hold "--" nor end in "-" (entities are not read
// there): each '-' after a '-' becomes "_" and a last '-' gets a space after it.
std::string xml_comment(const std::string& s) {
  std::string out;
  for (const char c : s) out += c == '-' && !out.empty() && out.back() == '-' ? '_' : c;
  if (!out.empty() && out.back() == '-') out += ' ';
  return out;
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
  if (!xml_can_hold(h5_name)) return "";
  const std::size_t frames = times.size(), every = (frames + max_frames - 1) / max_frames;
  std::ostringstream q;
  q << "<DataItem Dimensions=\"" << frames << " " << coordinates.size()
    << "\" NumberType=\"Float\" Precision=\"8\" Format=\"HDF\">" << xml_text(h5_name) << ":/q</DataItem>";
  const std::string source = q.str();
  std::ostringstream out;
  out << "<?xml version=\"1.0\" ?>\n"
      << "<!-- nonholo: the bodies' centres in " << xml_comment(h5_name) << " as a time series (ParaView: open this file) -->\n"
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
