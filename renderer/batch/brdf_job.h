// The library entry point of `lamina brdf` (docs/contracts.md, "lamina brdf"): a method, its
// options and a stack in, the table, totals and notes out. The command line
// (renderer/cli/brdf.cpp) parses and prints around it; the Python package (python/, docs/python.md)
// calls it too, so that both give the same numbers bit for bit.
#pragma once

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

struct BrdfRequest {
  BrdfMethod method = BrdfMethod::MonteCarlo;
  // theta_i, phi_i, samples, bins, seed, the walk's roulette cap (walk.forced_exponential_after),
  // on_progress (monte-carlo; it may throw to stop the walks).
  BrdfOptions options;
  int quadrature_points = AddingDoublingSettings{}.quadrature_points;  // adding-doubling
  bool table = true;  // adding-doubling: also the table (one solution per Fourier mode)
};

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
