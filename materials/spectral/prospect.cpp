#include "materials/spectral/prospect.h"

#include <cmath>
#include <stdexcept>
#include <string>

#include "materials/spectral/tables.h"

namespace lamina {
namespace {

using spectral_tables::kProspectD;
using spectral_tables::kProspectDRows;
using Row = spectral_tables::ProspectRow;

constexpr double kPi = 3.14159265358979323846;
// The half-angle of the incident cone PROSPECT assumes for a measurement with an integrating
// sphere (Jacquemoud and Baret 1990, section 2).
constexpr double kIncidentCone = 40.0;

// A member of the table at nm, linear between the nanometres of the table, held at its ends.
double coefficient(double Row::*member, double nm) {
  const double x = nm - kProspectD[0].nm;
  if (x <= 0.0) return kProspectD[0].*member;
  if (x >= kProspectDRows - 1) return kProspectD[kProspectDRows - 1].*member;
  const int i = static_cast<int>(x);
  const double t = x - i;
  return (1.0 - t) * (kProspectD[i].*member) + t * (kProspectD[i + 1].*member);
}

}  // namespace

WavelengthGrid prospect_grid() { return {kProspectD[0].nm, 1.0, kProspectDRows}; }

// Stern (1964), Appl. Opt. 3:111, for s polarisation and Allen (1973), J. Opt. Soc. Am. 63:664
// for the generalisation to a cone; PROSPECT's tav function (Jacquemoud and Baret 1990,
// appendix). With a = (n+1)^2/2, k = -(n^2-1)^2/4 and b = sqrt((sin^2 alpha - (n^2+1)/2)^2 + k)
// - (sin^2 alpha - (n^2+1)/2), the s and p parts integrate in closed form between a and b.
double average_transmissivity(double alpha_degrees, double n) {
  const double n2 = n * n, np = n2 + 1.0, nm = n2 - 1.0;
  const double a = (n + 1.0) * (n + 1.0) / 2.0;
  const double k = -(n2 - 1.0) * (n2 - 1.0) / 4.0;
  const double sa = std::sin(alpha_degrees * kPi / 180.0);
  const double b2 = sa * sa - np / 2.0;
  const double b1 = alpha_degrees == 90.0 ? 0.0 : std::sqrt(b2 * b2 + k);
  const double b = b1 - b2;
  const double ts = (k * k / (6.0 * b * b * b) + k / b - b / 2.0) - (k * k / (6.0 * a * a * a) + k / a - a / 2.0);
  const double tp1 = -2.0 * n2 * (b - a) / (np * np);
  const double tp2 = -2.0 * n2 * np * std::log(b / a) / (nm * nm);
  const double tp3 = n2 * (1.0 / b - 1.0 / a) / 2.0;
  const double tp4 = 16.0 * n2 * n2 * (n2 * n2 + 1.0) * std::log((2.0 * np * b - nm * nm) / (2.0 * np * a - nm * nm)) /
                     (np * np * np * nm * nm);
  const double tp5 = 16.0 * n2 * n2 * n2 * (1.0 / (2.0 * np * b - nm * nm) - 1.0 / (2.0 * np * a - nm * nm)) / (np * np * np);
  return (ts + tp1 + tp2 + tp3 + tp4 + tp5) / (2.0 * sa * sa);
}

// Diffuse light crossing a slab of absorption optical thickness k: the transmission averaged
// over the cosine-weighted hemisphere, 2 int_0^1 e^(-k/mu) mu dmu = (1 - k) e^-k + k^2 E1(k)
// (Allen et al. 1969). E1(k) = -Ei(-k).
double diffuse_transmission(double k) {
  if (k <= 0.0) return 1.0;
  return (1.0 - k) * std::exp(-k) - k * k * std::expint(-k);
}

// A plate: interfaces 1 (air | leaf) and 2 (leaf | air) around an interior that transmits tau.
// The light entering through the top within the cone alpha is transmitted with t_alpha; inside,
// the light is diffuse, and leaves through either face with t21 = t12 / n^2 (the hemispherical
// transmissivity from inside, by reciprocity), the rest bouncing with r21 = 1 - t21. Summing
// the bounces between the faces (a geometric series in r21^2 tau^2):
//   T = t_alpha tau t21 / (1 - r21^2 tau^2),   R = r_alpha + r21 tau T.
PlateOptics plate(double alpha_degrees, double n, double tau, bool incident) {
  const double t12 = average_transmissivity(90.0, n);
  const double t_in = incident ? average_transmissivity(alpha_degrees, n) : t12;
  const double t21 = t12 / (n * n);
  const double r21 = 1.0 - t21;
  const double t = t_in * tau * t21 / (1.0 - r21 * r21 * tau * tau);
  return {1.0 - t_in + r21 * tau * t, t};
}

// Stokes (1862), the closed form of Jacquemoud and Baret (1990, eqs. 9-12) for N - 1 plates of
// (r, t): with D = sqrt((1+r+t)(1+r-t)(1-r+t)(1-r-t)), a = (1 + r^2 - t^2 + D) / 2r and
// b = (1 - r^2 + t^2 + D) / 2t,
//   R = a (b^(2(N-1)) - 1) / (a^2 b^(2(N-1)) - 1),  T = b^(N-1) (a^2 - 1) / (a^2 b^(2(N-1)) - 1).
// Without absorption (r + t = 1) the limit is T = t / (t + (1 - t)(N - 1)), R = 1 - T.
PlateOptics stokes_pile(const PlateOptics& one, double plates) {
  const double r = one.reflectance, t = one.transmittance;
  if (r + t >= 1.0) {
    const double tn = t / (t + (1.0 - t) * (plates - 1.0));
    return {1.0 - tn, tn};
  }
  const double d = std::sqrt((1.0 + r + t) * (1.0 + r - t) * (1.0 - r + t) * (1.0 - r - t));
  const double a = (1.0 + r * r - t * t + d) / (2.0 * r);
  const double b = (1.0 - r * r + t * t + d) / (2.0 * t);
  const double b_nm1 = std::pow(b, plates - 1.0);
  const double denom = a * a * b_nm1 * b_nm1 - 1.0;
  return {a * (b_nm1 * b_nm1 - 1.0) / denom, b_nm1 * (a * a - 1.0) / denom};
}

double prospect_d_absorption(const LeafContents& p, double nm) {
  return p.chlorophyll * coefficient(&Row::chlorophyll, nm) + p.carotenoids * coefficient(&Row::carotenoids, nm) +
         p.anthocyanins * coefficient(&Row::anthocyanins, nm) + p.brown * coefficient(&Row::brown, nm) +
         p.water * coefficient(&Row::water, nm) + p.dry_matter * coefficient(&Row::dry_matter, nm);
}

double prospect_refractive_index(double nm) { return coefficient(&Row::n, nm); }

// The leaf: its top plate (lit within the cone) over the pile of the other N - 1 plates, which
// are lit diffusely; each plate absorbs k = K / N. The two combine as two plates do:
//   T = T_top T_sub / (1 - R_sub r),  R = R_top + T_top R_sub t / (1 - R_sub r),
// r and t the top plate's for diffuse light from below (by symmetry its diffuse values).
PlateOptics prospect_d(const ProspectParameters& p, double nm) {
  const double n = prospect_refractive_index(nm);
  const double tau = diffuse_transmission(prospect_d_absorption(p, nm) / p.n);
  const PlateOptics top = plate(kIncidentCone, n, tau, true);
  const PlateOptics diffuse = plate(kIncidentCone, n, tau, false);
  const PlateOptics sub = stokes_pile(diffuse, p.n);
  const double denom = 1.0 - sub.reflectance * diffuse.reflectance;
  return {top.reflectance + top.transmittance * sub.reflectance * diffuse.transmittance / denom,
          top.transmittance * sub.transmittance / denom};
}

void validate(const ProspectParameters& p) {
  auto check = [](double v, double lo, const char* name) {
    if (!(std::isfinite(v) && v >= lo))
      throw std::invalid_argument(std::string("prospect: ") + name + " must be finite and >= " + (lo > 0.0 ? "1" : "0"));
  };
  check(p.n, 1.0, "n");
  check(p.chlorophyll, 0.0, "chlorophyll");
  check(p.carotenoids, 0.0, "carotenoids");
  check(p.anthocyanins, 0.0, "anthocyanins");
  check(p.brown, 0.0, "brown");
  check(p.water, 0.0, "water");
  check(p.dry_matter, 0.0, "dry_matter");
}

}  // namespace lamina
