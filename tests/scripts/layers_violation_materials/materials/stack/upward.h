// Fixture for check_layers: a concept folder of materials/ must not include one above it.
#include "materials/walk/random_walk.h"
