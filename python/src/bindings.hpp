// python/src/bindings.hpp: the parts of `shearzone._native` defined outside module.cpp.
#pragma once

#include <pybind11/pybind11.h>

/// Scenes (dicts of the scene file's sections) and checkpoints read as arrays (sim.cpp).
void bind_sim(pybind11::module_& m);
