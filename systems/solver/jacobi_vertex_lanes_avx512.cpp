// jacobi_vertex_lanes.cpp compiled for AVX-512 (F and VL): the same kernels, each particle read and
// written with one masked instruction (point_lanes.h, nucleon/lanes.h).
#define NUCLEON_LANES_AVX512 1
#include "systems/solver/jacobi_vertex_lanes.cpp"
