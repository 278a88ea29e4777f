// Every constraint pool of a world, one per family and simplex kind.
#pragma once

#include "components/constraint_pool.h"

namespace nucleon {

struct ConstraintPools {
  StretchConstraints stretch;  // type 1 on every edge
  AngleConstraints shear;      // type 2 at the corners of cloth triangles
  AngleConstraints curveBend;  // type 2 where two rope segments meet  } the "bend" family
  DihedralConstraints bend;    // type 3 on the hinges of cloth        }
  DihedralConstraints twist;   // type 3 on four consecutive rope points
  VolumeConstraints volume;    // tetrahedra of solids
  TetherConstraints tether;    // free particle to pins of its nearest pin clusters, unilateral

  template <class F>
  void forEach(F&& f) {
    f(stretch);
    f(shear);
    f(curveBend);
    f(bend);
    f(twist);
    f(volume);
    f(tether);
  }
  std::size_t count(ConstraintFamily family) const {
    switch (family) {
      case ConstraintFamily::Stretch:
        return stretch.size();
      case ConstraintFamily::Shear:
        return shear.size();
      case ConstraintFamily::Bend:
        return bend.size() + curveBend.size();
      case ConstraintFamily::Twist:
        return twist.size();
      case ConstraintFamily::Volume:
        return volume.size();
      case ConstraintFamily::Tether:
        return tether.size();
    }
    return 0;
  }
};

}  // namespace nucleon
