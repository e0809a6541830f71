// Fixture for check_layers: materials/ must not include renderer/.
#include "renderer/util/progress.h"
