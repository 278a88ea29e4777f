#include "components/primitive_bvh.h"

#include <algorithm>
#include <atomic>
#include <cmath>

#include <embree3/rtcore.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_invoke.h>

namespace nucleon {

namespace {

// A node of a flattened binary tree, in depth-first order: an inner node's first child is the next
// node and `link` is its second; a leaf holds the primitives leafPrimitive[link .. link + count).
struct FlatNode {
  float lower[3];
  std::uint32_t link;
  float upper[3];
  std::uint32_t count;  // 0: an inner node
};

// Closed float boxes (nodes or primitive boxes), as `overlaps`: an empty box (lower above upper)
// overlaps nothing, without a test of its own.
template <class A, class B>
[[gnu::always_inline]] inline bool boxesOverlap(const A& a, const B& b) {
  return a.lower[0] <= b.upper[0] && b.lower[0] <= a.upper[0] && a.lower[1] <= b.upper[1] &&
         b.lower[1] <= a.upper[1] && a.lower[2] <= b.upper[2] && b.lower[2] <= a.upper[2];
}

// The nodes Embree's builder makes, before they are flattened.
constexpr unsigned kMaxLeafSize = 4;
struct BuildNode {
  BuildNode* child[2];
  unsigned count;  // 0: an inner node
  unsigned primitive[kMaxLeafSize];
};

void* createNode(RTCThreadLocalAllocator allocator, unsigned int, void*) {
  auto* node = static_cast<BuildNode*>(
      rtcThreadLocalAlloc(allocator, sizeof(BuildNode), alignof(BuildNode)));
  node->child[0] = node->child[1] = nullptr;
  node->count = 0;
  return node;
}
void setNodeChildren(void* node, void** children, unsigned int count, void*) {
  for (unsigned k = 0; k < count && k < 2; ++k)
    static_cast<BuildNode*>(node)->child[k] = static_cast<BuildNode*>(children[k]);
}
void setNodeBounds(void*, const RTCBounds**, unsigned int, void*) {}  // the refit sets them
void* createLeaf(RTCThreadLocalAllocator allocator, const RTCBuildPrimitive* primitives,
                 size_t count, void*) {
  auto* node = static_cast<BuildNode*>(
      rtcThreadLocalAlloc(allocator, sizeof(BuildNode), alignof(BuildNode)));
  node->child[0] = node->child[1] = nullptr;
  node->count = static_cast<unsigned>(std::min<size_t>(count, kMaxLeafSize));
  for (unsigned k = 0; k < node->count; ++k) node->primitive[k] = primitives[k].primID;
  return node;
}

// A flattened tree: its nodes, the primitives of its leaves leaf by leaf, and their boxes in the
// same order (copied at each refit, so that a leaf's boxes are read together).
struct FlatTree {
  std::vector<FlatNode> nodes;
  std::vector<Index> leafPrimitive;
  std::vector<PrimitiveBox> leafBox;
  bool built() const { return !nodes.empty(); }
};

// Pairs reported to the caller's visitor a batch at a time.
struct PairBatch {
  PairBatch(PrimitiveBvh::PairVisitor v, void* c) : visit(v), context(c) {}
  PrimitiveBvh::PairVisitor visit;
  void* context;
  static constexpr std::size_t kSize = 256;
  Index a[kSize], b[kSize];
  std::size_t count = 0;

  void add(Index first, Index second) {
    a[count] = first, b[count] = second;
    if (++count == kSize) flush();
  }
  void flush() {
    if (count > 0) visit(context, a, b, count);
    count = 0;
  }
};

}  // namespace

// Per tree, a binary tree over the tree's boxes whose topology Embree's builder makes
// (rtcBuildBVH, binned SAH, up to kMaxLeafSize boxes per leaf) and whose node bounds, traversals
// and refits are ours.
struct PrimitiveBvh::Embree {
  RTCDevice device = nullptr;
  std::atomic<std::size_t> errors{0};
  std::array<FlatTree, kBvhTreeCount> tree;

  Embree() {
    // threads=0 leaves the thread count to oneTBB, so a build runs in the caller's task arena
    // with its concurrency (Embree's TBB scheduler only installs a global_control when a count
    // is given).
    device = rtcNewDevice("threads=0,verbose=0");
    if (!device) {
      ++errors;
      return;
    }
    rtcSetDeviceErrorFunction(
        device,
        [](void* counter, RTCError, const char*) {
          ++*static_cast<std::atomic<std::size_t>*>(counter);
        },
        &errors);
  }
  ~Embree() {
    if (device) rtcReleaseDevice(device);
  }
  Embree(const Embree&) = delete;
  Embree& operator=(const Embree&) = delete;

  void release(std::size_t t) {
    tree[t].nodes.clear();
    tree[t].leafPrimitive.clear();
    tree[t].leafBox.clear();
  }

  // The topology from Embree's builder over the boxes as they are now. An empty box is built as
  // the point at the origin: the builder needs finite, ordered bounds, and the refit that follows
  // gives the node its true (empty) box.
  void build(std::size_t t, const std::vector<PrimitiveBox>& boxes) {
    release(t);
    if (boxes.empty()) return;
    if (!device) {
      singleLeaf(tree[t], boxes.size());
      return;
    }
    std::vector<RTCBuildPrimitive> primitives(boxes.size());
    for (std::size_t i = 0; i < boxes.size(); ++i) {
      const PrimitiveBox& box = boxes[i];
      RTCBuildPrimitive& p = primitives[i];
      if (box.isEmpty()) {
        p.lower_x = p.lower_y = p.lower_z = p.upper_x = p.upper_y = p.upper_z = 0;
      } else {
        p.lower_x = box.lower[0], p.lower_y = box.lower[1], p.lower_z = box.lower[2];
        p.upper_x = box.upper[0], p.upper_y = box.upper[1], p.upper_z = box.upper[2];
      }
      p.geomID = 0;
      p.primID = static_cast<unsigned>(i);
    }
    RTCBVH bvh = rtcNewBVH(device);
    if (!bvh) {
      singleLeaf(tree[t], boxes.size());
      return;
    }
    RTCBuildArguments arguments = rtcDefaultBuildArguments();
    arguments.buildQuality = RTC_BUILD_QUALITY_MEDIUM;
    arguments.maxBranchingFactor = 2;
    arguments.maxDepth = 64;
    arguments.minLeafSize = 1;
    arguments.maxLeafSize = kMaxLeafSize;
    arguments.bvh = bvh;
    arguments.primitives = primitives.data();
    arguments.primitiveCount = primitives.size();
    arguments.primitiveArrayCapacity = primitives.size();
    arguments.createNode = &createNode;
    arguments.setNodeChildren = &setNodeChildren;
    arguments.setNodeBounds = &setNodeBounds;
    arguments.createLeaf = &createLeaf;
    const auto* root = static_cast<const BuildNode*>(rtcBuildBVH(&arguments));
    if (root) flatten(tree[t], root, boxes.size());
    rtcReleaseBVH(bvh);
    if (!root || tree[t].leafPrimitive.size() != boxes.size()) singleLeaf(tree[t], boxes.size());
  }

  // A failed build (the device's error, or a leaf the builder made larger than asked) leaves the
  // tree one leaf of every box: slow (every pair is tested) but complete, and counted.
  void singleLeaf(FlatTree& out, std::size_t count) {
    ++errors;
    out.nodes.assign(1, FlatNode{{0, 0, 0}, 0, {0, 0, 0}, static_cast<std::uint32_t>(count)});
    out.leafPrimitive.resize(count);
    for (std::size_t i = 0; i < count; ++i) out.leafPrimitive[i] = static_cast<Index>(i);
    out.leafBox.resize(count);
  }

  static void flatten(FlatTree& out, const BuildNode* root, std::size_t primitives) {
    out.nodes.clear();
    out.leafPrimitive.clear();
    out.leafPrimitive.reserve(primitives);
    // Depth first, first child first; a second child's place is written when it is reached.
    std::vector<std::pair<const BuildNode*, std::size_t>> stack{{root, ~std::size_t{0}}};
    while (!stack.empty()) {
      const auto [node, parent] = stack.back();
      stack.pop_back();
      const std::size_t index = out.nodes.size();
      if (parent != ~std::size_t{0}) out.nodes[parent].link = static_cast<std::uint32_t>(index);
      FlatNode flat{};
      if (node->count > 0) {
        flat.link = static_cast<std::uint32_t>(out.leafPrimitive.size());
        flat.count = node->count;
        for (unsigned k = 0; k < node->count; ++k) out.leafPrimitive.push_back(node->primitive[k]);
        out.nodes.push_back(flat);
        continue;
      }
      out.nodes.push_back(flat);
      stack.push_back({node->child[1], index});
      stack.push_back({node->child[0], ~std::size_t{0}});
    }
    out.leafBox.resize(out.leafPrimitive.size());
  }

  // Node bounds from the boxes: the leaves' boxes copied in leaf order, then every node as the box
  // of its children (an empty box adds nothing: its lower corner is above every upper one), the
  // subtrees of the top levels in parallel and each of theirs from its last node to its first
  // (children follow their parents in depth-first order).
  void refit(std::size_t t, const std::vector<PrimitiveBox>& boxes) {
    FlatTree& tr = tree[t];
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, tr.leafPrimitive.size(), 4096),
                      [&](const tbb::blocked_range<std::size_t>& r) {
                        for (std::size_t k = r.begin(); k != r.end(); ++k)
                          tr.leafBox[k] = boxes[tr.leafPrimitive[k]];
                      });
    refitSubtree(tr, 0, 0);
  }

  // The boxes of node i's subtree, children before parents.
  static void refitSubtree(FlatTree& tr, std::uint32_t i, int depth) {
    const FlatNode& top = tr.nodes[i];
    if (top.count == 0 && depth < kRefitTaskDepth) {
      tbb::parallel_invoke([&] { refitSubtree(tr, i + 1, depth + 1); },
                           [&] { refitSubtree(tr, top.link, depth + 1); });
      refitNode(tr, i);
      return;
    }
    // The subtree's nodes run from i to its last leaf, reached down the second children.
    std::uint32_t last = i;
    while (tr.nodes[last].count == 0) last = tr.nodes[last].link;
    for (std::uint32_t k = last + 1; k-- > i;) refitNode(tr, k);
  }

  // The box of a leaf's boxes or of an inner node's two children.
  static void refitNode(FlatTree& tr, std::uint32_t i) {
    constexpr float kBig = 3.0e38f;
    FlatNode& node = tr.nodes[i];
    float lower[3] = {kBig, kBig, kBig}, upper[3] = {-kBig, -kBig, -kBig};
    const auto add = [&](const auto& box) {
      for (int k = 0; k < 3; ++k) lower[k] = std::min(lower[k], box.lower[k]);
      for (int k = 0; k < 3; ++k) upper[k] = std::max(upper[k], box.upper[k]);
    };
    if (node.count > 0) {
      for (std::uint32_t k = node.link; k < node.link + node.count; ++k) add(tr.leafBox[k]);
    } else {
      add(tr.nodes[i + 1]);
      add(tr.nodes[node.link]);
    }
    for (int k = 0; k < 3; ++k) node.lower[k] = lower[k], node.upper[k] = upper[k];
  }
  static constexpr int kRefitTaskDepth = 4;
};

namespace {

// Children of inner node i.
inline std::uint32_t firstChild(std::uint32_t i) {
  return i + 1;
}

// Which of two nodes a dual traversal splits: the one that is not a leaf, the larger if neither
// is (true: the first).
inline bool splitFirst(const FlatNode& a, const FlatNode& b) {
  const auto extent = [](const FlatNode& n) {
    return (n.upper[0] - n.lower[0]) + (n.upper[1] - n.lower[1]) + (n.upper[2] - n.lower[2]);
  };
  return b.count > 0 || (a.count == 0 && extent(a) >= extent(b));
}

// Every pair of a leaf of `a` and a leaf of `b` under nodes i and j whose boxes overlap: the
// larger node is split until both are leaves. `self`: a and b are one tree, and i and j are
// disjoint subtrees of it (each pair is then met once); pairs are reported as (lower, higher).
void collideNodes(const FlatTree& a, std::uint32_t i, const FlatTree& b, std::uint32_t j, bool self,
                  PairBatch& out) {
  const FlatNode& ni = a.nodes[i];
  const FlatNode& nj = b.nodes[j];
  if (!boxesOverlap(ni, nj)) return;
  if (ni.count > 0 && nj.count > 0) {
    for (std::uint32_t p = ni.link; p < ni.link + ni.count; ++p)
      for (std::uint32_t q = nj.link; q < nj.link + nj.count; ++q) {
        if (!boxesOverlap(a.leafBox[p], b.leafBox[q])) continue;
        const Index first = a.leafPrimitive[p], second = b.leafPrimitive[q];
        if (self)
          out.add(std::min(first, second), std::max(first, second));
        else
          out.add(first, second);
      }
    return;
  }
  if (splitFirst(ni, nj)) {
    collideNodes(a, firstChild(i), b, j, self, out);
    collideNodes(a, ni.link, b, j, self, out);
  } else {
    collideNodes(a, i, b, firstChild(j), self, out);
    collideNodes(a, i, b, nj.link, self, out);
  }
}

// Every pair of primitives under node i of one tree whose boxes overlap, once each.
void collideWithin(const FlatTree& t, std::uint32_t i, PairBatch& out) {
  const FlatNode& node = t.nodes[i];
  if (node.count > 0) {
    for (std::uint32_t p = node.link; p < node.link + node.count; ++p)
      for (std::uint32_t q = p + 1; q < node.link + node.count; ++q) {
        if (!boxesOverlap(t.leafBox[p], t.leafBox[q])) continue;
        const Index first = t.leafPrimitive[p], second = t.leafPrimitive[q];
        out.add(std::min(first, second), std::max(first, second));
      }
    return;
  }
  collideWithin(t, firstChild(i), out);
  collideWithin(t, node.link, out);
  collideNodes(t, firstChild(i), t, node.link, true, out);
}

// Splits the traversal into tasks for the top `depth` levels, then runs each part on one thread
// with a batch of its own.
constexpr int kTaskDepth = 9;

void collideNodesParallel(const FlatTree& a, std::uint32_t i, const FlatTree& b, std::uint32_t j,
                          bool self, PrimitiveBvh::PairVisitor visit, void* context, int depth) {
  const FlatNode& ni = a.nodes[i];
  const FlatNode& nj = b.nodes[j];
  if (!boxesOverlap(ni, nj)) return;
  if (depth >= kTaskDepth || (ni.count > 0 && nj.count > 0)) {
    PairBatch batch{visit, context};
    collideNodes(a, i, b, j, self, batch);
    batch.flush();
    return;
  }
  if (splitFirst(ni, nj)) {
    tbb::parallel_invoke(
        [&] { collideNodesParallel(a, firstChild(i), b, j, self, visit, context, depth + 1); },
        [&] { collideNodesParallel(a, ni.link, b, j, self, visit, context, depth + 1); });
  } else {
    tbb::parallel_invoke(
        [&] { collideNodesParallel(a, i, b, firstChild(j), self, visit, context, depth + 1); },
        [&] { collideNodesParallel(a, i, b, nj.link, self, visit, context, depth + 1); });
  }
}

void collideWithinParallel(const FlatTree& t, std::uint32_t i, PrimitiveBvh::PairVisitor visit,
                           void* context, int depth) {
  const FlatNode& node = t.nodes[i];
  if (depth >= kTaskDepth || node.count > 0) {
    PairBatch batch{visit, context};
    collideWithin(t, i, batch);
    batch.flush();
    return;
  }
  tbb::parallel_invoke([&] { collideWithinParallel(t, firstChild(i), visit, context, depth + 1); },
                       [&] { collideWithinParallel(t, node.link, visit, context, depth + 1); },
                       [&] {
                         collideNodesParallel(t, firstChild(i), t, node.link, true, visit, context,
                                              depth + 1);
                       });
}

}  // namespace

PrimitiveBvh::PrimitiveBvh() = default;
PrimitiveBvh::~PrimitiveBvh() = default;
PrimitiveBvh::PrimitiveBvh(PrimitiveBvh&&) noexcept = default;
PrimitiveBvh& PrimitiveBvh::operator=(PrimitiveBvh&&) noexcept = default;

bool PrimitiveBvh::commit() {
  bool rebuilt = false;
  for (std::size_t t = 0; t < kBvhTreeCount; ++t) {
    const std::vector<PrimitiveBox>& treeBoxes = boxes[t];
    if (treeBoxes.empty()) {
      if (embree_) embree_->release(t);
      rebuilt |= builtCount_[t] != 0;
      builtCount_[t] = 0;
      continue;
    }
    // The device is made on first use: a world without collisions never starts Embree.
    if (!embree_) embree_ = std::make_unique<Embree>();
    if (embree_->tree[t].built() && builtCount_[t] == treeBoxes.size()) {
      ++refits_;
    } else {
      embree_->build(t, treeBoxes);
      builtCount_[t] = embree_->tree[t].built() ? treeBoxes.size() : 0;
      ++builds_;
      rebuilt = true;
    }
    if (embree_->tree[t].built()) embree_->refit(t, treeBoxes);
  }
  return rebuilt;
}

void PrimitiveBvh::forEachOverlap(BvhTree tree, const PrimitiveBox& query, Visitor visit,
                                  void* context) const {
  const std::size_t t = static_cast<std::size_t>(tree);
  if (!embree_ || !embree_->tree[t].built() || query.isEmpty()) return;
  const FlatTree& tr = embree_->tree[t];
  std::uint32_t stack[128];
  int top = 0;
  stack[top++] = 0;
  while (top > 0) {
    const std::uint32_t i = stack[--top];
    const FlatNode& node = tr.nodes[i];
    if (!boxesOverlap(node, query)) continue;
    if (node.count > 0) {
      for (std::uint32_t k = node.link; k < node.link + node.count; ++k)
        if (boxesOverlap(tr.leafBox[k], query)) visit(context, tr.leafPrimitive[k]);
      continue;
    }
    stack[top++] = node.link;
    stack[top++] = firstChild(i);
  }
}

void PrimitiveBvh::forEachOverlappingPair(BvhTree treeA, BvhTree treeB, PairVisitor visit,
                                          void* context) const {
  const std::size_t a = static_cast<std::size_t>(treeA), b = static_cast<std::size_t>(treeB);
  if (!embree_ || !embree_->tree[a].built() || !embree_->tree[b].built()) return;
  if (a == b)
    collideWithinParallel(embree_->tree[a], 0, visit, context, 0);
  else
    collideNodesParallel(embree_->tree[a], 0, embree_->tree[b], 0, false, visit, context, 0);
}

std::size_t PrimitiveBvh::embreeErrors() const {
  return embree_ ? embree_->errors.load() : 0;
}

}  // namespace nucleon
