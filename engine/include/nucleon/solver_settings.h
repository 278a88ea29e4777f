// Which backend solves the constraints, and how many substeps and sweeps it takes.
#pragma once

#include <string>

#include "nucleon/schedule.h"
#include "nucleon/types.h"

namespace nucleon {

enum class SolverKind { GaussSeidel, Jacobi, ColoredGaussSeidel, Multigrid };
const char* toString(SolverKind kind);
// Parses "gauss-seidel", "jacobi", "colored-gs", "multigrid"; returns false on anything else.
bool parseSolverKind(const std::string& name, SolverKind& out);

struct SolverSettings {
  SolverKind kind = SolverKind::GaussSeidel;
  int iterations = 10;  // sweeps per substep of every family, when `schedule` is empty
  int substeps = 1;     // substeps per step(dt)
  // Jacobi relaxation ω in (0, 2): each particle moves by ω times the average of its
  // constraints' corrections. Ignored by the Gauss–Seidel backends.
  Real relaxation = 1;
  // Multigrid: sweeps of each coarse level in the coarse-to-fine cascade that precedes the fine
  // sweeps of every substep (ARCHITECTURE.md §3).
  int sweepsPerLevel = 4;
  // Per-family sweep counts and order; empty = every family `iterations` times, in the order
  // stretch, tether, shear, bend, twist, volume.
  Schedule schedule;
};

}  // namespace nucleon
