// A quick look at a world: ray-casts its current state with Embree into a PNG picture.
#pragma once

#include <string>

#include "nucleon/world.h"

namespace nucleon {

struct RenderSettings {
  int width = 960;
  int height = 720;
  Real fieldOfViewDegrees = 40;
};

// Renders cloth, solids and colliders as shaded surfaces, ropes as tubes of their thickness and
// particles as spheres, over a checkered ground plane below the lowest point, with the camera
// framing the bounding box of all objects. Throws std::runtime_error if the file cannot be
// written.
void renderPng(const World& world, const std::string& path, const RenderSettings& settings = {});

}  // namespace nucleon
