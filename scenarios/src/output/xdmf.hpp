#pragma once
// The XDMF sidecar of a run's HDF5 file (FILE.h5 -> FILE.xdmf): an XML description that lets
// ParaView (and VisIt) open the bodies' centres as a time series of points, read straight from
// the file's /q by hyperslabs (no copy of the data), with each planar body's heading as a point
// attribute. The centres are the coordinates named x, y (and z), numbered per body (x0, y0, x1,
// ...) at a constant stride; a model without them (the Suslov top) gets no sidecar.
#include <string>
#include <vector>

namespace nonholo::scenarios {

// The XML, or "" when the coordinates have no centres to show or XML 1.0 cannot hold `h5_name`
// (a control character, invalid UTF-8). The name is escaped (&, <, > as entities; no "--" in the
// comment that mentions it), so no file name changes the document's structure. `h5_name`: the HDF5 file as the
// sidecar refers to it (its name, the two side by side); `times`: /t; at most `max_frames`
// frames are listed (every k-th, the last always), ParaView's time steps.
std::string xdmf_for(const std::string& h5_name, const std::vector<std::string>& coordinates,
                     const std::vector<double>& times, std::size_t max_frames = 10000);

}  // namespace nonholo::scenarios
