// The library entry point of `lamina brdf` (docs/contracts.md, "lamina brdf"): a method, its
// options and a stack in, the table, totals and notes out. The command line
// (renderer/cli/brdf.cpp) parses and prints around it; the Python package (python/, docs/python.md)
// calls it too, so that both give the same numbers bit for bit.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "materials/adding_doubling/adding_doubling.h"
#include "materials/brdf/brdf_table.h"
#include "materials/stack/stack.h"

namespace lamina {

enum class BrdfMethod { FirstOrder, MonteCarlo, AddingDoubling };

// "first-order", "monte-carlo", "adding-doubling"; false for another name.
bool parse_brdf_method(const std::string& name, BrdfMethod* method);
const char* brdf_method_name(BrdfMethod method);
std::vector<std::string> brdf_method_names();  // in the order of the enum

struct BrdfRequest {
  BrdfMethod method = BrdfMethod::MonteCarlo;
  // theta_i, phi_i, samples, bins, seed, the walk's roulette cap (walk.forced_exponential_after),
  // on_progress (monte-carlo; it may throw to stop the walks).
  BrdfOptions options;
  int quadrature_points = AddingDoublingSettings{}.quadrature_points;  // adding-doubling
  bool table = true;  // adding-doubling: also the table (one solution per Fourier mode)
};

// One option of a BrdfRequest, declared once: `lamina brdf`'s flag and help (renderer/cli/brdf.cpp
// adds one CLI11 option per row) and the Python keyword (lamina.brdf; the flag without its
// dashes, '-' as '_', python/src/module.cpp) derive from its row of kBrdfOptionTable, with the
// accepted range and the member it sets. A new brdf option is a member and one row.
struct BrdfOptionSpec {
  enum class Kind {
    Real,     // a finite double in [lo, hi] (either end open)
    Integer,  // an int in [lo, hi]
    Count,    // a std::uint64_t in [lo, hi]
    Seed,     // a std::uint64_t, any
    Method,   // a BrdfMethod by its name
  };
  const char* flag;  // "--theta-i"
  const char* help;
  Kind kind;
  double lo = 0.0, hi = 0.0;
  bool lo_open = false, hi_open = false;
  bool required = false;  // no default (theta_i)
  double* (*real)(BrdfRequest*) = nullptr;
  int* (*integer)(BrdfRequest*) = nullptr;
  std::uint64_t* (*count)(BrdfRequest*) = nullptr;  // Count and Seed
};

// In the order of `lamina brdf --help`.
extern const std::vector<BrdfOptionSpec> kBrdfOptionTable;

// The Python keyword of an option: "--theta-i" -> "theta_i".
std::string brdf_option_keyword(const BrdfOptionSpec& spec);
// The option's value in `request` as `lamina brdf` would take it ("45", "monte-carlo").
std::string brdf_option_text(const BrdfOptionSpec& spec, const BrdfRequest& request);

// The largest table: bins_theta x bins_phi (a typo catcher).
inline constexpr long long kMaxBrdfBinsTotal = 1000000;
// What no single option can check: throws std::invalid_argument with a one-line message naming
// the options by their flags (the bins' product).
void check_brdf_request(const BrdfRequest& request);

struct BrdfResult {
  BrdfTable table;  // every method's totals; adding-doubling's bins only with BrdfRequest::table
  bool has_table = true;
  // adding-doubling: the totals with diffuse incidence and the discretisation error.
  AddingDoublingEstimate adding_doubling;
  // Notes for the user, one line each (delta-M's truncation too coarse for the bins, ...).
  std::vector<std::string> notes;
};

// Throws std::runtime_error naming `source` (the stack's file) when the method cannot solve the
// stack (a rough top with first-order or adding-doubling). compute_brdf checks it first.
void check_brdf_method(const LayerStack& stack, const std::string& source, BrdfMethod method);
BrdfResult compute_brdf(const LayerStack& stack, const std::string& source, const BrdfRequest& request);

}  // namespace lamina
