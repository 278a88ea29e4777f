// Which instruction set the solver's batched kernels run with.
//
// The kernels that project constraints eight at a time (systems/solver: distance_batch.cpp,
// angular_batch.cpp, jacobi_vertex_lanes.cpp) are compiled twice: for AVX2 with FMA, and again in
// the *_avx512.cpp files for AVX-512 (F and VL), where a particle's twelve bytes are read and
// written with one masked instruction instead of two (point_lanes.h). Both compiles do the same
// IEEE operations in the same order, so they give the same bits: the choice changes the speed,
// never the state. The best set the CPU has is used unless another is selected (benchmarks
// compare them: `nucleon bench --lanes avx2,avx512`). Float builds on x86-64 only; elsewhere the
// set is None and the scalar paths run.
#pragma once

#include <string_view>

namespace nucleon {

enum class LaneIsa { None, Avx2, Avx512 };

// The set the batched kernels use now (None: this build or CPU has none; the scalar paths run).
LaneIsa laneIsa();

// The best set this build and CPU can run.
LaneIsa bestLaneIsa();

// Makes the batched kernels use `isa` from their next call on; false, and no change, where this
// build or CPU cannot run it. A process-wide switch. Switching between the two sets while a
// world steps changes nothing in its state; switching to or from None changes the rounding from
// then on (the scalar paths round differently), so a benchmark or test selects between steps.
bool selectLaneIsa(LaneIsa isa);

// "none", "avx2", "avx512": the names the command line and the benchmark records use.
const char* laneIsaName(LaneIsa isa);

// The set of a name above; false for any other name.
bool parseLaneIsa(std::string_view name, LaneIsa& isa);

}  // namespace nucleon
