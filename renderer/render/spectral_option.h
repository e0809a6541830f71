// The spectral mode's option, declared once: its `lamina render` flag and help, and the EXR
// header key a spectral render carries (docs/contracts.md; an RGB render's header has no such
// key, so RGB outputs are as they were). Its value is RenderSettings::spectral; what it does is
// materials/spectral/sampled_wavelengths.h (paths) and docs/spectral.md, "Spectral rendering".
#pragma once

namespace lamina {

struct SpectralOption {
  const char* flag;
  const char* exr_key;
  const char* exr_value;  // what a spectral render's header says of its transport
  const char* help;
};

inline constexpr SpectralOption kSpectralOption{
    "--spectral", "lamina:spectral", "hero wavelength 360-830 nm; RGB uplift Mallett-Yuksel 2019; CIE 1931 2-degree to linear Rec. 709",
    "spectral transport: each path carries three wavelengths (hero-wavelength sampling, 360-830 nm), RGB inputs are "
    "uplifted to smooth spectra, skin chromophore layers are evaluated per wavelength and the film integrates CIE XYZ, "
    "written as linear Rec. 709 as in the RGB mode; the table and lambert modes interpolate tables computed on a wavelength grid"};

// The option's name without the flag's dashes: the batch manifest's key ("settings" and each
// scene, docs/batch.md) and the Python keyword of lamina.render (docs/python.md).
constexpr const char* spectral_option_key() { return kSpectralOption.flag + 2; }

}  // namespace lamina
