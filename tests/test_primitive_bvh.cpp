// The broad phase's trees (components/primitive_bvh.h) against every pair of boxes: a tree met
// with itself reports each overlapping pair once, as a < b, two trees every overlapping pair once,
// and a box query every overlapping box once, on random boxes, on boxes all alike (the builder's
// degenerate input), on empty boxes and on one-box trees; after a refit of moved boxes, the new
// overlaps and no old ones.
#include <algorithm>
#include <cstdint>
#include <mutex>
#include <random>
#include <span>
#include <vector>

#include <tbb/task_arena.h>

#include <gtest/gtest.h>

#include "components/primitive_bvh.h"

namespace nucleon {
namespace {

bool overlapping(const PrimitiveBox& a, const PrimitiveBox& b) {
  if (a.isEmpty() || b.isEmpty()) return false;
  for (int k = 0; k < 3; ++k)
    if (a.lower[k] > b.upper[k] || b.lower[k] > a.upper[k]) return false;
  return true;
}

std::vector<PrimitiveBox> randomBoxes(std::mt19937& random, std::size_t count, float world,
                                      float size) {
  std::uniform_real_distribution<float> place(-world, world), extent(0, size);
  std::vector<PrimitiveBox> boxes(count);
  for (PrimitiveBox& box : boxes)
    for (int k = 0; k < 3; ++k) {
      box.lower[k] = place(random);
      box.upper[k] = box.lower[k] + extent(random);
    }
  return boxes;
}

// Every reported pair, as a sorted list with its repeats kept (so that a pair reported twice
// shows).
struct Collected {
  std::vector<std::uint64_t> pairs;
};
void collect(void* context, const Index* a, const Index* b, std::size_t count) {
  auto& out = static_cast<Collected*>(context)->pairs;
  static std::mutex lock;
  const std::lock_guard<std::mutex> guard(lock);
  for (std::size_t k = 0; k < count; ++k) out.push_back(std::uint64_t{a[k]} << 32 | b[k]);
}
void collectOne(void* context, Index primitive) {
  auto& out = static_cast<Collected*>(context)->pairs;
  out.push_back(primitive);
}

std::vector<std::uint64_t> reportedPairs(const PrimitiveBvh& bvh, BvhTree a, BvhTree b) {
  Collected collected;
  bvh.forEachOverlappingPair(a, b, &collect, &collected);
  std::sort(collected.pairs.begin(), collected.pairs.end());
  return collected.pairs;
}

std::vector<std::uint64_t> expectedPairs(const std::vector<PrimitiveBox>& a,
                                         const std::vector<PrimitiveBox>& b, bool self) {
  std::vector<std::uint64_t> pairs;
  for (std::size_t i = 0; i < a.size(); ++i)
    for (std::size_t j = self ? i + 1 : 0; j < b.size(); ++j)
      if (overlapping(a[i], b[j])) pairs.push_back(std::uint64_t{i} << 32 | j);
  return pairs;
}

void expectTreesMatchTheBruteForce(PrimitiveBvh& bvh) {
  const auto& edges = bvh.boxes[static_cast<std::size_t>(BvhTree::Edges)];
  const auto& triangles = bvh.boxes[static_cast<std::size_t>(BvhTree::Triangles)];
  EXPECT_EQ(reportedPairs(bvh, BvhTree::Edges, BvhTree::Edges), expectedPairs(edges, edges, true));
  EXPECT_EQ(reportedPairs(bvh, BvhTree::Edges, BvhTree::Triangles),
            expectedPairs(edges, triangles, false));
  std::mt19937 random(7);
  for (const PrimitiveBox& query : randomBoxes(random, 50, 1, 0.5f)) {
    Collected collected;
    bvh.forEachOverlap(BvhTree::Triangles, query, &collectOne, &collected);
    std::sort(collected.pairs.begin(), collected.pairs.end());
    std::vector<std::uint64_t> expected;
    for (std::size_t i = 0; i < triangles.size(); ++i)
      if (overlapping(query, triangles[i])) expected.push_back(i);
    EXPECT_EQ(collected.pairs, expected);
  }
  EXPECT_EQ(bvh.embreeErrors(), 0u);
}

TEST(PrimitiveBvh, RandomBoxesGiveEveryOverlappingPairOnce) {
  for (int threads : {1, 2}) {
    tbb::task_arena arena(threads);
    arena.execute([&] {
      std::mt19937 random(threads);
      for (std::size_t count : {1u, 2u, 5u, 300u, 3000u}) {
        PrimitiveBvh bvh;
        bvh.boxes[static_cast<std::size_t>(BvhTree::Edges)] = randomBoxes(random, count, 1, 0.2f);
        bvh.boxes[static_cast<std::size_t>(BvhTree::Triangles)] =
            randomBoxes(random, count + 7, 1, 0.2f);
        bvh.commit();
        SCOPED_TRACE(count);
        expectTreesMatchTheBruteForce(bvh);
        // Moved boxes, refit on the same topology.
        bvh.boxes[static_cast<std::size_t>(BvhTree::Edges)] = randomBoxes(random, count, 1, 0.3f);
        bvh.boxes[static_cast<std::size_t>(BvhTree::Triangles)] =
            randomBoxes(random, count + 7, 1, 0.3f);
        EXPECT_FALSE(bvh.commit());  // refit, not rebuilt
        expectTreesMatchTheBruteForce(bvh);
      }
    });
  }
}

TEST(PrimitiveBvh, IdenticalAndEmptyBoxes) {
  PrimitiveBvh bvh;
  // 500 copies of one box: every pair overlaps (124,750 of them), each reported once.
  const PrimitiveBox box{{0, 0, 0}, {1, 1, 1}};
  bvh.boxes[static_cast<std::size_t>(BvhTree::Edges)].assign(500, box);
  // Triangles: every third box empty; built with them, and refit after they become boxes.
  std::mt19937 random(3);
  std::vector<PrimitiveBox> triangles = randomBoxes(random, 900, 1, 0.3f);
  for (std::size_t i = 0; i < triangles.size(); i += 3) triangles[i] = PrimitiveBox::empty();
  bvh.boxes[static_cast<std::size_t>(BvhTree::Triangles)] = triangles;
  bvh.commit();
  EXPECT_EQ(reportedPairs(bvh, BvhTree::Edges, BvhTree::Edges).size(), 500u * 499u / 2);
  expectTreesMatchTheBruteForce(bvh);
  // The empty ones now boxes far from where they were built (at the origin), the others empty.
  for (std::size_t i = 0; i < triangles.size(); ++i)
    triangles[i] = i % 3 == 0 ? PrimitiveBox{{5, 5, 5}, {5.5f, 5.5f, 5.5f}} : PrimitiveBox::empty();
  bvh.boxes[static_cast<std::size_t>(BvhTree::Triangles)] = triangles;
  bvh.boxes[static_cast<std::size_t>(BvhTree::Edges)].assign(500,
                                                             PrimitiveBox{{5, 5, 5}, {6, 6, 6}});
  bvh.commit();
  expectTreesMatchTheBruteForce(bvh);
  EXPECT_EQ(reportedPairs(bvh, BvhTree::Edges, BvhTree::Triangles).size(), 500u * 300u);
}

}  // namespace
}  // namespace nucleon
