// Names of the domain enums as the scene format and the command line spell them.
#include <string>

#include "nucleon/object_def.h"
#include "nucleon/schedule.h"
#include "nucleon/solver_settings.h"

namespace nucleon {

const char* toString(ObjectKind kind) {
  switch (kind) {
    case ObjectKind::Cloth:
      return "cloth";
    case ObjectKind::Rope:
      return "rope";
    case ObjectKind::Solid:
      return "solid";
    case ObjectKind::Particles:
      return "particles";
    case ObjectKind::Collider:
      return "collider";
  }
  return "?";
}

const char* toString(SolverKind kind) {
  switch (kind) {
    case SolverKind::GaussSeidel:
      return "gauss-seidel";
    case SolverKind::Jacobi:
      return "jacobi";
    case SolverKind::ColoredGaussSeidel:
      return "colored-gs";
    case SolverKind::Multigrid:
      return "multigrid";
  }
  return "?";
}

bool parseSolverKind(const std::string& name, SolverKind& out) {
  for (SolverKind k : {SolverKind::GaussSeidel, SolverKind::Jacobi, SolverKind::ColoredGaussSeidel,
                       SolverKind::Multigrid})
    if (name == toString(k)) {
      out = k;
      return true;
    }
  return false;
}

const char* toString(ConstraintFamily family) {
  switch (family) {
    case ConstraintFamily::Stretch:
      return "stretch";
    case ConstraintFamily::Shear:
      return "shear";
    case ConstraintFamily::Bend:
      return "bend";
    case ConstraintFamily::Twist:
      return "twist";
    case ConstraintFamily::Volume:
      return "volume";
    case ConstraintFamily::Tether:
      return "tether";
  }
  return "?";
}

bool parseConstraintFamily(const std::string& name, ConstraintFamily& out) {
  for (std::size_t f = 0; f < kConstraintFamilyCount; ++f)
    if (name == toString(static_cast<ConstraintFamily>(f))) {
      out = static_cast<ConstraintFamily>(f);
      return true;
    }
  return false;
}

}  // namespace nucleon
