// Test hooks of materials/adding_doubling/adding_doubling.cpp, for tests only.
#pragma once

namespace lamina::adding_doubling_test_hooks {

// Under a rough top, double and add the layers on every node, the incidences included (the plain
// path), instead of on the real nodes alone (adding_doubling.cpp, DroppedNodes and
// add_bottom_run); the results are the same numbers either way, which the tests check. Read
// by each solution as it starts: set it between calls, from one thread.
extern bool double_on_every_node;

}  // namespace lamina::adding_doubling_test_hooks
