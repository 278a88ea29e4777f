#include "systems/topology/remove_object.h"

#include <algorithm>

#include "systems/solver/pressure.h"

namespace nucleon {

namespace {

// Erases [first, first + count) of one column.
template <class T>
void eraseRange(std::vector<T>& column, Index first, Index count) {
  column.erase(column.begin() + first, column.begin() + first + count);
}

template <class Pool>
void removeFromPool(Pool& pool, const ObjectRemoval& removal) {
  pool.retain([&](std::size_t c) {
    for (std::size_t k = 0; k < pool.arity(); ++k)
      if (removal.removesParticle(pool.particle(c, k))) return false;
    return true;
  });
}

template <std::size_t N>
void renumber(ConstraintPool<N>& pool, const ObjectRemoval& removal) {
  for (auto& constraint : pool.particles)
    for (Index& i : constraint) i = removal.particle(i);
}

void renumber(UserConstraintPool& pool, const ObjectRemoval& removal) {
  for (Index& i : pool.particles) i = removal.particle(i);
}

void removeFromAttachments(AttachmentPool& pool, const ObjectRemoval& removal,
                           std::size_t& marked) {
  for (std::size_t a = 0; a < pool.size(); ++a) {
    auto& ids = pool.particles[a];
    const bool touches =
        std::any_of(ids.begin(), ids.end(), [&](Index i) { return removal.removesParticle(i); });
    if (touches) {
      marked += !pool.removed[a];
      pool.removed[a] = 1;
      // A removed row is skipped before its particles are read; 0 keeps it in range anyway.
      ids.fill(0);
    } else {
      for (Index& i : ids) i = removal.particle(i);
    }
  }
  for (KinematicTrack& track : pool.tracks) {
    if (track.object == removal.object) continue;  // its attachment is marked removed above
    track.object = removal.objectIndex(track.object);
    track.firstParticle = removal.particle(track.firstParticle);
  }
}

void removeFromShapeMatching(ShapeMatchPool& pool, const ObjectRemoval& removal) {
  ShapeMatchPool kept;
  kept.blockSums = std::move(pool.blockSums);
  for (std::size_t c = 0; c < pool.size(); ++c) {
    if (pool.object[c] == removal.object) continue;
    for (Index k = pool.particleBegin[c]; k < pool.particleBegin[c + 1]; ++k) {
      kept.particles.push_back(removal.particle(pool.particles[k]));
      kept.masses.push_back(pool.masses[k]);
      kept.rest.push_back(pool.rest[k]);
    }
    kept.particleBegin.push_back(static_cast<Index>(kept.particles.size()));
    kept.object.push_back(removal.objectIndex(pool.object[c]));
    kept.rigidity.push_back(pool.rigidity[c]);
    kept.mass.push_back(pool.mass[c]);
  }
  pool = std::move(kept);
}

// The liquid's particle list is object by object: the removed liquid's run leaves it, the later
// runs move down, and the per-particle columns follow (the multipliers' sums are read after the
// step; the rest is scratch refilled every substep).
void removeFromLiquids(LiquidPool& pool, const ObjectRemoval& removal) {
  const auto entry =
      std::find_if(pool.objects.begin(), pool.objects.end(),
                   [&](const LiquidObject& o) { return o.object == removal.object; });
  if (entry != pool.objects.end()) {
    const Index begin = entry->begin, count = entry->end - entry->begin;
    const auto removedEntry = static_cast<std::uint32_t>(entry - pool.objects.begin());
    pool.objects.erase(entry);
    for (LiquidObject& o : pool.objects)
      if (o.begin >= begin + count) o.begin -= count, o.end -= count;
    eraseRange(pool.particle, begin, count);
    eraseRange(pool.objectOf, begin, count);
    for (std::uint32_t& o : pool.objectOf) o -= o > removedEntry;
    if (pool.lambdaTotal.size() >= begin + count) eraseRange(pool.lambdaTotal, begin, count);
    const std::size_t n = pool.particle.size();
    pool.density.resize(n), pool.lambda.resize(n), pool.lambdaOverDensity.resize(n);
    pool.delta.resize(n), pool.vorticity.resize(n), pool.normal.resize(n);
    pool.lambdaTotal.resize(n);
  }
  for (LiquidObject& o : pool.objects) o.object = removal.objectIndex(o.object);
  for (Index& i : pool.particle) i = removal.particle(i);
}

// Rebuilt from the object table: each surviving surface is appended as when its object was
// added, then given back its gas and its last multiplier.
void removeFromPressure(PressurePool& pool, const std::vector<ObjectRecord>& objects,
                        const ObjectRemoval& removal) {
  PressurePool rebuilt;
  for (std::size_t k = 0; k < pool.size(); ++k) {
    if (pool.object[k] == removal.object) continue;
    const Index object = removal.objectIndex(pool.object[k]);
    appendPressureSurface(rebuilt, objects[object], object);
    rebuilt.settings.back() = pool.settings[k];
    rebuilt.restVolume.back() = pool.restVolume[k];
    rebuilt.gas.back() = pool.gas[k];
    rebuilt.lambda.back() = pool.lambda[k];
  }
  rebuilt.collapsedProjections = pool.collapsedProjections;
  rebuilt.limitedSteps = pool.limitedSteps;
  pool = std::move(rebuilt);
}

}  // namespace

void removeParticles(ParticlePool& particles, const ObjectRemoval& removal) {
  const Index first = removal.firstParticle, count = removal.particleCount;
  eraseRange(particles.x, first, count);
  eraseRange(particles.v, first, count);
  eraseRange(particles.p, first, count);
  eraseRange(particles.w, first, count);
  eraseRange(particles.phase, first, count);
  eraseRange(particles.restPosition, first, count);
  for (std::uint32_t& phase : particles.phase) phase = removal.objectIndex(phase);
}

std::size_t removeObjectConstraints(ConstraintPools& pools,
                                    const std::vector<ObjectRecord>& objects,
                                    const ObjectRemoval& removal) {
  pools.forEach([&](auto& pool) {
    removeFromPool(pool, removal);
    renumber(pool, removal);
  });
  std::size_t marked = 0;
  removeFromAttachments(pools.attachments, removal, marked);
  removeFromShapeMatching(pools.shapeMatching, removal);
  removeFromLiquids(pools.liquid, removal);
  removeFromPressure(pools.pressure, objects, removal);
  return marked;
}

void removeObjectTracks(KinematicTracks& kinematics, const ObjectRemoval& removal) {
  KinematicTracks kept;
  for (KinematicTrack& track : kinematics.tracks) {
    if (track.object == removal.object) continue;
    const auto targets = kinematics.target.begin() + track.firstTarget;
    track.firstTarget = static_cast<Index>(kept.target.size());
    kept.target.insert(kept.target.end(), targets, targets + track.particleCount);
    track.object = removal.objectIndex(track.object);
    track.firstParticle = removal.particle(track.firstParticle);
    for (Index& i : track.particles) i = removal.particle(i);
    kept.tracks.push_back(std::move(track));
  }
  kinematics = std::move(kept);
}

void removeObjectExclusions(std::vector<std::uint64_t>& excludedObjectPairs,
                            std::vector<VertexSetExclusion>& excludedVertexSets,
                            const ObjectRemoval& removal) {
  std::vector<std::uint64_t> pairs;
  for (std::uint64_t key : excludedObjectPairs) {
    const auto a = static_cast<Index>(key >> 32), b = static_cast<Index>(key & 0xffffffffu);
    if (a == removal.object || b == removal.object) continue;
    pairs.push_back(CollisionPrimitives::pairKey(removal.objectIndex(a), removal.objectIndex(b)));
  }
  excludedObjectPairs = std::move(pairs);
  const auto keep = [&](std::vector<Index>& set) {
    std::erase_if(set, [&](Index i) { return removal.removesParticle(i); });
    for (Index& i : set) i = removal.particle(i);
    return !set.empty();
  };
  std::erase_if(excludedVertexSets, [&](VertexSetExclusion& rule) {
    const bool a = keep(rule.a), b = keep(rule.b);
    return !(a && b);
  });
}

}  // namespace nucleon
