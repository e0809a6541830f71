// Dwivedi's zero-variance-based direction and distance sampling towards a surface, for guided
// random walks in bright media (Krivanek and d'Eon 2014, "A zero-variance-based sampling scheme
// for Monte Carlo subsurface scattering"; d'Eon and Krivanek 2020, "A zero-variance theory for
// efficient subsurface scattering"). In a half-space of single-scattering albedo alpha the
// radiance deep inside decays as exp(-z / (v0 mfp)) with v0 the root of
//     1 = alpha v0 atanh(1 / v0)   (v0 > 1; v0 -> infinity as alpha -> 1),
// and the zero-variance walk towards the surface samples the cosine mu with the outward normal
// from p(mu) = 1 / (ln((v0 + 1) / (v0 - 1)) (v0 - mu)) on [-1, 1] and the distance with the
// stretched coefficient sigma_t (1 - mu / v0). Used only as one technique of a mixture with the
// classic walk (WalkOptions::guiding), so the estimator stays unbiased whatever v0 is.
#pragma once

namespace lamina {

// v0 for a (reduced) single-scattering albedo: the fit of d'Eon and Krivanek 2020, eq. 67,
// 1 / sqrt(1 - alpha^(2.44294 - 0.0215813 alpha + 0.578637 / alpha)), valid for alpha >= 0.56;
// below that (little to gain) and at alpha >= 1 (no finite root) it returns 0: no guiding.
double dwivedi_v0(double alpha);

// The guided density of a direction whose cosine with the outward normal is mu, per steradian
// (p(mu) / (2 pi)). v0 > 1.
double dwivedi_pdf(double v0, double mu);

// Inverts the CDF of p(mu): mu = v0 - (v0 + 1) ((v0 - 1) / (v0 + 1))^u, u in [0, 1).
double sample_dwivedi_cos(double v0, double u);

}  // namespace lamina
