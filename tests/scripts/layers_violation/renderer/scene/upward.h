// Fixture for check_layers: scene/ must not include render/ (a layer above it).
#include "renderer/render/integrator.h"
