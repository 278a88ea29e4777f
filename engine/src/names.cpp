// Names of the domain enums as the scene format and the command line spell them.
#include <string>

#include "nucleon/attachments.h"
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

const char* toString(AttachmentKind kind) {
  switch (kind) {
    case AttachmentKind::PointToPoint:
      return "point";
    case AttachmentKind::PointToSurface:
      return "surface";
    case AttachmentKind::SlideOnSurface:
      return "slide";
    case AttachmentKind::PointToTransform:
      return "transform";
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

namespace {
constexpr const char* kFamilyNames[] = {
#define NUCLEON_FAMILY_NAME(enumerator, name, pools) name,
    NUCLEON_CONSTRAINT_FAMILIES(NUCLEON_FAMILY_NAME)
#undef NUCLEON_FAMILY_NAME
};
}  // namespace

const char* toString(ConstraintFamily family) {
  return isBuiltin(family) ? kFamilyNames[familyIndex(family)] : "user";
}

bool parseConstraintFamily(const std::string& name, ConstraintFamily& out) {
  for (std::size_t f = 0; f < kBuiltinFamilyCount; ++f)
    if (name == kFamilyNames[f]) {
      out = static_cast<ConstraintFamily>(f);
      return true;
    }
  return false;
}

}  // namespace nucleon
