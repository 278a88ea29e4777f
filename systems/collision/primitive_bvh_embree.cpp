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
  // Per node, the tag of its primitives (combineTags over them), set at each refit; and whether
  // the primitives had tags (without, the traversals look at none).
  std::vector<std::uint32_t> nodeTag;
  bool tagged = false;
  bool built() const { return !nodes.empty(); }
};

// The tag of a set of primitives from two of its parts' tags: one object if both are of it, free
// if either is.
inline std::uint32_t combineTags(std::uint32_t a, std::uint32_t b) {
  const std::uint32_t objectA = a & kMixedObject, objectB = b & kMixedObject;
  return (objectA == objectB ? objectA : kMixedObject) | ((a | b) & kFreeTag);
}

// Whether no pair of a primitive tagged `a` and one tagged `b` can be kept: none can move, or
// their objects never collide.
inline bool holdNoPair(std::uint32_t a, std::uint32_t b, const ObjectExclusions& exclusions) {
  if (!((a | b) & kFreeTag)) return true;
  const std::uint32_t objectA = a & kMixedObject, objectB = b & kMixedObject;
  return objectA != kMixedObject && objectB != kMixedObject &&
         exclusions.excluded(objectA, objectB);
}

// Pairs reported to the caller's visitor a batch at a time.
struct PairBatch {
  PairBatch(PrimitiveBvh::PairVisitor v, void* c, const ObjectExclusions& e,
            std::atomic<std::size_t>& p)
      : visit(v), context(c), exclusions(e), passedOverTotal(p) {}
  ~PairBatch() {
    if (passedOver > 0) passedOverTotal += passedOver;
  }
  PairBatch(const PairBatch&) = delete;
  PairBatch& operator=(const PairBatch&) = delete;
  PrimitiveBvh::PairVisitor visit;
  void* context;
  const ObjectExclusions& exclusions;
  std::atomic<std::size_t>& passedOverTotal;
  std::size_t passedOver = 0;
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
  std::atomic<std::size_t> passedOver{0};
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
    tree[t].nodeTag.clear();
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
    out.nodeTag.resize(1);
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
    out.nodeTag.resize(out.nodes.size());
  }

  // Node bounds from the boxes: the leaves' boxes copied in leaf order, then every node as the box
  // of its children (an empty box adds nothing: its lower corner is above every upper one), the
  // subtrees of the top levels in parallel and each of theirs from its last node to its first
  // (children follow their parents in depth-first order).
  // Tags as the node bounds, from the primitives' tags; without a tag per box every node is
  // tagged kMixedObject | kFreeTag and nothing is passed over.
  void refit(std::size_t t, const std::vector<PrimitiveBox>& boxes,
             const std::vector<std::uint32_t>& tags) {
    FlatTree& tr = tree[t];
    const std::uint32_t* tag = tags.size() == boxes.size() ? tags.data() : nullptr;
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, tr.leafPrimitive.size(), 4096),
                      [&](const tbb::blocked_range<std::size_t>& r) {
                        for (std::size_t k = r.begin(); k != r.end(); ++k)
                          tr.leafBox[k] = boxes[tr.leafPrimitive[k]];
                      });
    refitSubtree(tr, 0, 0, tag);
    tr.tagged = tag != nullptr;
  }

  // The boxes of node i's subtree, children before parents.
  static void refitSubtree(FlatTree& tr, std::uint32_t i, int depth, const std::uint32_t* tag) {
    const FlatNode& top = tr.nodes[i];
    if (top.count == 0 && depth < kRefitTaskDepth) {
      tbb::parallel_invoke([&] { refitSubtree(tr, i + 1, depth + 1, tag); },
                           [&] { refitSubtree(tr, top.link, depth + 1, tag); });
      refitNode(tr, i, tag);
      return;
    }
    // The subtree's nodes run from i to its last leaf, reached down the second children.
    std::uint32_t last = i;
    while (tr.nodes[last].count == 0) last = tr.nodes[last].link;
    for (std::uint32_t k = last + 1; k-- > i;) refitNode(tr, k, tag);
  }

  // The box of a leaf's boxes or of an inner node's two children, and its tag.
  static void refitNode(FlatTree& tr, std::uint32_t i, const std::uint32_t* tag) {
    constexpr float kBig = 3.0e38f;
    FlatNode& node = tr.nodes[i];
    float lower[3] = {kBig, kBig, kBig}, upper[3] = {-kBig, -kBig, -kBig};
    const auto add = [&](const auto& box) {
      for (int k = 0; k < 3; ++k) lower[k] = std::min(lower[k], box.lower[k]);
      for (int k = 0; k < 3; ++k) upper[k] = std::max(upper[k], box.upper[k]);
    };
    std::uint32_t nodeTag = kMixedObject | kFreeTag;
    if (node.count > 0) {
      for (std::uint32_t k = node.link; k < node.link + node.count; ++k) add(tr.leafBox[k]);
      if (tag) {
        nodeTag = tag[tr.leafPrimitive[node.link]];
        for (std::uint32_t k = node.link + 1; k < node.link + node.count; ++k)
          nodeTag = combineTags(nodeTag, tag[tr.leafPrimitive[k]]);
      }
    } else {
      add(tr.nodes[i + 1]);
      add(tr.nodes[node.link]);
      nodeTag = combineTags(tr.nodeTag[i + 1], tr.nodeTag[node.link]);
    }
    for (int k = 0; k < 3; ++k) node.lower[k] = lower[k], node.upper[k] = upper[k];
    tr.nodeTag[i] = nodeTag;
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
// kPrune: pass over pairs of subtrees whose tags hold no pair (holdNoPair).
template <bool kPrune>
void collideNodes(const FlatTree& a, std::uint32_t i, const FlatTree& b, std::uint32_t j, bool self,
                  PairBatch& out) {
  const FlatNode& ni = a.nodes[i];
  const FlatNode& nj = b.nodes[j];
  if (!boxesOverlap(ni, nj)) return;
  if constexpr (kPrune)
    if (holdNoPair(a.nodeTag[i], b.nodeTag[j], out.exclusions)) {
      ++out.passedOver;
      return;
    }
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
    collideNodes<kPrune>(a, firstChild(i), b, j, self, out);
    collideNodes<kPrune>(a, ni.link, b, j, self, out);
  } else {
    collideNodes<kPrune>(a, i, b, firstChild(j), self, out);
    collideNodes<kPrune>(a, i, b, nj.link, self, out);
  }
}

// Every pair of primitives under node i of one tree whose boxes overlap, once each.
template <bool kPrune>
void collideWithin(const FlatTree& t, std::uint32_t i, PairBatch& out) {
  const FlatNode& node = t.nodes[i];
  if constexpr (kPrune)
    if (holdNoPair(t.nodeTag[i], t.nodeTag[i], out.exclusions)) {
      ++out.passedOver;
      return;
    }
  if (node.count > 0) {
    for (std::uint32_t p = node.link; p < node.link + node.count; ++p)
      for (std::uint32_t q = p + 1; q < node.link + node.count; ++q) {
        if (!boxesOverlap(t.leafBox[p], t.leafBox[q])) continue;
        const Index first = t.leafPrimitive[p], second = t.leafPrimitive[q];
        out.add(std::min(first, second), std::max(first, second));
      }
    return;
  }
  collideWithin<kPrune>(t, firstChild(i), out);
  collideWithin<kPrune>(t, node.link, out);
  collideNodes<kPrune>(t, firstChild(i), t, node.link, true, out);
}

// Splits the traversal into tasks for the top `depth` levels, then runs each part on one thread
// with a batch of its own.
constexpr int kTaskDepth = 9;

// The traversal's constants, shared by its tasks.
struct Traversal {
  PrimitiveBvh::PairVisitor visit;
  void* context;
  const ObjectExclusions& exclusions;
  std::atomic<std::size_t>& passedOver;
};

template <bool kPrune>
void collideNodesParallel(const FlatTree& a, std::uint32_t i, const FlatTree& b, std::uint32_t j,
                          bool self, const Traversal& traversal, int depth) {
  const FlatNode& ni = a.nodes[i];
  const FlatNode& nj = b.nodes[j];
  if (!boxesOverlap(ni, nj)) return;
  if constexpr (kPrune)
    if (holdNoPair(a.nodeTag[i], b.nodeTag[j], traversal.exclusions)) {
      ++traversal.passedOver;
      return;
    }
  if (depth >= kTaskDepth || (ni.count > 0 && nj.count > 0)) {
    PairBatch batch{traversal.visit, traversal.context, traversal.exclusions, traversal.passedOver};
    collideNodes<kPrune>(a, i, b, j, self, batch);
    batch.flush();
    return;
  }
  if (splitFirst(ni, nj)) {
    tbb::parallel_invoke(
        [&] { collideNodesParallel<kPrune>(a, firstChild(i), b, j, self, traversal, depth + 1); },
        [&] { collideNodesParallel<kPrune>(a, ni.link, b, j, self, traversal, depth + 1); });
  } else {
    tbb::parallel_invoke(
        [&] { collideNodesParallel<kPrune>(a, i, b, firstChild(j), self, traversal, depth + 1); },
        [&] { collideNodesParallel<kPrune>(a, i, b, nj.link, self, traversal, depth + 1); });
  }
}

template <bool kPrune>
void collideWithinParallel(const FlatTree& t, std::uint32_t i, const Traversal& traversal,
                           int depth) {
  const FlatNode& node = t.nodes[i];
  if constexpr (kPrune)
    if (holdNoPair(t.nodeTag[i], t.nodeTag[i], traversal.exclusions)) {
      ++traversal.passedOver;
      return;
    }
  if (depth >= kTaskDepth || node.count > 0) {
    PairBatch batch{traversal.visit, traversal.context, traversal.exclusions, traversal.passedOver};
    collideWithin<kPrune>(t, i, batch);
    batch.flush();
    return;
  }
  tbb::parallel_invoke(
      [&] { collideWithinParallel<kPrune>(t, firstChild(i), traversal, depth + 1); },
      [&] { collideWithinParallel<kPrune>(t, node.link, traversal, depth + 1); },
      [&] {
        collideNodesParallel<kPrune>(t, firstChild(i), t, node.link, true, traversal, depth + 1);
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
    if (embree_->tree[t].built()) embree_->refit(t, treeBoxes, tags[t]);
  }
  return rebuilt;
}

void PrimitiveBvh::forEachOverlap(BvhTree tree, const PrimitiveBox& query, Visitor visit,
                                  void* context, std::uint32_t queryTag) const {
  const std::size_t t = static_cast<std::size_t>(tree);
  if (!embree_ || !embree_->tree[t].built() || query.isEmpty()) return;
  const FlatTree& tr = embree_->tree[t];
  const bool prune = tr.tagged;
  std::uint32_t stack[128];
  int top = 0;
  stack[top++] = 0;
  std::size_t passed = 0;
  while (top > 0) {
    const std::uint32_t i = stack[--top];
    const FlatNode& node = tr.nodes[i];
    if (!boxesOverlap(node, query)) continue;
    if (prune && holdNoPair(queryTag, tr.nodeTag[i], exclusions)) {
      ++passed;
      continue;
    }
    if (node.count > 0) {
      for (std::uint32_t k = node.link; k < node.link + node.count; ++k)
        if (boxesOverlap(tr.leafBox[k], query)) visit(context, tr.leafPrimitive[k]);
      continue;
    }
    stack[top++] = node.link;
    stack[top++] = firstChild(i);
  }
  if (passed > 0) embree_->passedOver += passed;
}

void PrimitiveBvh::forEachOverlappingPair(BvhTree treeA, BvhTree treeB, PairVisitor visit,
                                          void* context) const {
  const std::size_t a = static_cast<std::size_t>(treeA), b = static_cast<std::size_t>(treeB);
  if (!embree_ || !embree_->tree[a].built() || !embree_->tree[b].built()) return;
  const FlatTree &first = embree_->tree[a], &second = embree_->tree[b];
  const Traversal traversal{visit, context, exclusions, embree_->passedOver};
  // Pruning costs a tag lookup per node pair: only where a tag can say no.
  const bool prune = first.tagged || second.tagged;
  if (a == b) {
    if (prune)
      collideWithinParallel<true>(first, 0, traversal, 0);
    else
      collideWithinParallel<false>(first, 0, traversal, 0);
  } else if (prune) {
    collideNodesParallel<true>(first, 0, second, 0, false, traversal, 0);
  } else {
    collideNodesParallel<false>(first, 0, second, 0, false, traversal, 0);
  }
}

void PrimitiveBvh::setExclusions(const std::vector<std::uint64_t>& excludedPairs) {
  if (excludedPairs == exclusions.source) return;
  // Objects beyond the largest one named are excluded from nothing: the matrix stops there.
  std::size_t objects = 0;
  for (const std::uint64_t key : excludedPairs)
    objects = std::max<std::size_t>(objects, std::max(key >> 32, key & 0xffffffffu) + 1);
  if (objects > ObjectExclusions::kMaxObjects) objects = 0;
  exclusions.objects = objects;
  exclusions.source = excludedPairs;
  exclusions.bits.assign((objects * objects + 63) / 64, 0);
  exclusions.named.assign(objects, 0);
  for (const std::uint64_t key : excludedPairs) {
    const std::size_t low = key >> 32, high = key & 0xffffffffu;
    if (low >= objects || high >= objects) continue;
    exclusions.named[low] = exclusions.named[high] = 1;
    for (const std::size_t k : {low * objects + high, high * objects + low})
      exclusions.bits[k >> 6] |= std::uint64_t{1} << (k & 63);
  }
}

std::size_t PrimitiveBvh::passedOver() const {
  return embree_ ? embree_->passedOver.load() : 0;
}

std::size_t PrimitiveBvh::embreeErrors() const {
  return embree_ ? embree_->errors.load() : 0;
}

}  // namespace nucleon
