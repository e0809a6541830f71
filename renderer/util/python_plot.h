// Figures from the command line (`lamina brdf --plot`, `lamina compare --plot`): drawn by the
// Python package's matplotlib code (python/lamina/plot.py, docs/python.md), never in the render
// path. Why not C++: the figures are polar plots, hemispherical maps with colour bars, legends
// and histograms; renderer/image can write PNGs, false colour and text but has no axes, and a
// second plotting library in C++ would duplicate what matplotlib does for the package's users.
#pragma once

#include <string>
#include <vector>

namespace lamina {

// Runs `PYTHON -m lamina.plot ARGS...` and waits. PYTHON is $LAMINA_PYTHON if set, else the
// interpreter the package was built for (CMake's LAMINA_BUILD_PYTHON), else python3; the build
// tree's package comes first on PYTHONPATH, so it works before `pip install .`. Throws
// std::runtime_error (one line) if it cannot run or exits non-zero.
void run_python_plot(const std::vector<std::string>& args);

}  // namespace lamina
