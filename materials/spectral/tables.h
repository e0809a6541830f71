// The published spectra Lamina compiles in, as scripts/spectral_data.py writes them (the files
// *_data.cpp beside this one name each table's source and licence; docs/spectral.md lists them).
// Rows run by increasing wavelength (nm). Read them through the typed views of cie.h, prospect.h
// and chromophores.h, not directly.
#pragma once

namespace lamina::spectral_tables {

struct CieRow { double nm, x, y, z, d65; };
struct ProspectRow { double nm, n, chlorophyll, carotenoids, anthocyanins, brown, water, dry_matter; };
struct HaemoglobinRow { double nm, oxy, deoxy; };
struct SpectrumRow { double nm, value; };
struct BasisRow { double nm, r, g, b; };

extern const CieRow kCie1931[];
extern const int kCie1931Rows;
extern const double kXyzToRec709[3][3];
extern const ProspectRow kProspectD[];
extern const int kProspectDRows;
extern const HaemoglobinRow kHaemoglobin[];
extern const int kHaemoglobinRows;
extern const SpectrumRow kFat[];
extern const int kFatRows;
extern const BasisRow kMallett2019[];
extern const int kMallett2019Rows;

}  // namespace lamina::spectral_tables
