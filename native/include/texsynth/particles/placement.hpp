// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// Texture particles, placement on the surface (Dischler et al. 2002, §2.2-2.3;
// docs/algorithms/texture_particles.md, "Placement"): seeding per mesh component, breadth-first propagation
// through the co-occurrence lists along normal sections, overlap rejection against every particle placed so
// far, re-seeding of uncovered areas, random classes by dart throwing, each class brought to the sample's
// density, the artist's overrides.
//
// Frames and units (texture_particles.md, "Placement").
//  - At a surface point: n = smooth normal, up = the direction field (per-vertex, interpolated by
//    barycentrics, projected into the tangent plane, normalised; where it is shorter than 1e-3 the
//    parent's up projected, for a seed any vector perpendicular to n), right = normalize(up x n). Sample
//    x -> right, sample y -> up (right, up, n right-handed).
//  - Pixel size (world units per sample pixel) = sample_world_width / W / m, m = vertex_scale
//    interpolated (1 when absent).
//  - A particle's box angle theta (sample frame, from x) is its parent's theta + the entry's relative
//    angle, folded to (-pi/2, pi/2] (a box is the same turned by half a turn); seeds and random-class
//    particles keep their sprite's own box angle (drawn as in the sample). The sprite of source
//    particle s is drawn turned by fold(theta - theta_s), so sprites are never upside down.
//
// Placement of a child (entry (q, dx, dy, angle) of the parent's list): in the parent's box frame its
// centre lies at sx (hp_x u_p + dx g + eu u_c), sy (hp_y u_p + dy g + ev u_c), times 1/sqrt(f), where
// sx, sy are the quadrant's signs, hp the parent's box half extents, eu, ev the child box's extents
// along the parent's axes (its half extents turned by the entry angle), u = pixel size x size factor
// of parent / child (boxes scale with size overrides), f = the mean density override of both, and g =
// the mean pixel size of both for a positive gap (gaps do not grow with sizes: the paper's reason for
// box gaps) but the mean u for a negative one (an overlap along one axis, e.g. -20 for the row
// neighbour of a 20 px square, is a share of the boxes: kept in pixels it would shift rows of
// resized squares by 20 px). The offset is walked along the normal section from the parent
// (walk_normal_section); it is first computed with the child's factors taken at the parent, and walked
// again once with the factors found where the child landed when they differ.
//
// Rules.
//  - Sprite: uniform over the class's complete particles; one list per placed particle: the list of a
//    uniformly chosen complete particle with a non-empty list; its entries shuffled; breadth-first.
//  - Conflicts, with every particle placed so far (the paper's test; issue 30), in the candidate's tangent
//    plane (centres and axes projected), boxes scaled by 1/sqrt(f) like the offsets (else a lower density
//    scatters children beyond each other's boxes and raises the count: measured 1.12 x instead of 0.5 x).
//    With same-class particles (output or not):
//     (a) the paper's: box intersection > the class's overlap tolerance x the smaller box area;
//     (b) "a particle close to this location": the boxes grown by half the class's 10th-percentile
//         nearest box gap (max(dx, dy) over measured entries, when > 0) intersect by more than 1 % of
//         the smaller grown box. Without (b), an irregular sparse sample (jittered discs) came out 2.49 x
//         as dense as the sample, nearest distances 19.8 px against 29.5 (KS 0.81; the sample's halves
//         0.11): children of different parents squeezed into the gaps. With it: 1.32 x, 30.0 px, KS
//         0.18; the rest is the lattice order the propagation cannot keep over distance (25th
//         percentile: 1.15 x but 31.5 px, KS 0.39). Neighbours at exactly the gap never conflict, so
//         regular grids stay exact.
//    With output particles of another class: the same two tests with the pair's tolerance and margin
//    (ParticleAnalysis::class_pairs: what the sample shows between the two classes). Hidden ones (by
//    probability or density) do not count: their room belongs to the other classes. Before, classes were
//    independent: pebbles split into 2 classes by brightness came out 2.2-3.1 x the sample's density, 91 %
//    of the boxes overlapping one of the other class by more than 1 % (the sample's: none).
//    Particles whose normals face away (n1.n2 < 0) never conflict. A 3D hash grid finds them.
//  - A walk that stops before its length (wall, face limit, no plane) drops the child.
//  - Seeds: for every connected component of the walk mesh (faces joined across walkable edges) with
//    area, the given seeds that lie on it, else the point of it nearest its area centroid. Every class
//    starts from the same seeds (one refused by another class's particle there leaves it to re-seeding).
//  - Re-seeding, after propagation dies out: rounds of 64 area-weighted tries per component; a try is
//    seeded (then propagated) where no same-class particle lies within 2 x the class's mean neighbour
//    centre distance (scaled like gaps); rounds stop when none is seeded. Per-class cap: 4 x the
//    expected particle count (area / mean box area under the local scale, size and density).
//  - Random classes (1-3 particles, or no complete particle with a non-empty list): Poisson-disc dart
//    throwing at the class density (particles per sample pixel, per world area through the local pixel
//    size and density), minimum centre distance = the analysis's min distance scaled like gaps; at most
//    30 x the target count + 64 darts.
//  - Density: a class's expected count is its sample density (analysis, "Density") x the surface in
//    sample pixels^2 (area x density override / pixel size^2 per triangle). Propagation fills every gap
//    an irregular arrangement leaves (60 pebbles per 256^2 at random: 1.4-1.9 x the sample's density with
//    one class): a class holding more than (1 + kPlacementDensitySlack) x its expected count has particles
//    hidden down to the expected count, drawn from its stream with more weight where its local count is
//    higher (kPlacementThinExponent; stats: thinned). They stay in its arrangement (they keep its
//    particles apart). A class below (1 - kPlacementDensitySlack) x its
//    expected count after re-seeding (other classes took its room, or its lattice could not close) gets
//    darts like a random class up to it, or until kPlacementFillMisses darts in a row found no room
//    (origin filled; stats: filled). Within the slack nothing changes, so lattices whose count the border
//    moves a little stay whole.
//  - Overrides, per triangle: density f (0 = no particle there, else clamped to [0.05, 20]);
//    probability p in [0, 1] (a particle is placed and propagates, but is output with probability p);
//    size s (0 = no particle there, else clamped to [0.05, 20]; scales the box and the sprite, not the
//    gaps); size_jitter j in [0, 0.9]: each particle's size factor x uniform [1 - j, 1 + j].
//  - Output classes: every class of the order is placed up to the last output class (the later ones
//    cannot change it); only the output classes' rows and stats are returned.
//  - Determinism: class k draws from its own stream of (seed, k); walks of one generation run in
//    parallel, then children are accepted one by one in a fixed order: the same bytes at any thread
//    count, and output_classes = {k} gives exactly the rows class k got in the full run (unless
//    max_particles cut the run short).
#include <atomic>
#include <cstdint>
#include <vector>

#include "texsynth/particles/analysis.hpp"
#include "texsynth/particles/surface_walk.hpp"

namespace texsynth {

constexpr double kPlacementMinOverride = 0.05;  // density and size overrides are clamped to this..
constexpr double kPlacementMaxOverride = 20.0;  // ..and this (0 stays "no particle")
constexpr double kPlacementMaxJitter = 0.9;
constexpr int kPlacementReseedTries = 64;          // per component and round
constexpr double kPlacementReseedGaps = 2.0;       // x the class's mean neighbour centre distance
constexpr double kPlacementCapFactor = 4.0;        // x the expected count, per class
constexpr double kPlacementFieldZero = 1e-3;       // a projected field shorter than this is a zero
constexpr double kPlacementGrownTolerance = 0.01;  // grown boxes may intersect by this x the smaller
constexpr double kPlacementDensitySlack = 0.10;    // beyond (1 +- this) x its expected count: thinned / filled
constexpr int64_t kPlacementFillMisses = 256;       // filling a class stops after this many darts in a row miss
// Local count control (issue 30): a child is refused where its class already holds (1 + kPlacementCrowdSlack)
// x the expected count round it, both weighted by (1 - d^2 / r^2)^2 over the disc whose weighted expected
// count is kPlacementCrowdCount. The propagation fills every gap an irregular arrangement leaves (4-6 x the
// sample's count on the corpus' paving_bricks and flagstones), so from one seed it reached the class's cap in
// a disc round the seed, and thinning kept that disc: 1.45 x the density in the middle of a plane, 0.2-0.5 x
// along its edges. The expected count comes from the surface inside the disc, so that a disc at a boundary
// expects fewer and the edges are not overfilled. The slack keeps an exact grid whole (0.25 refused two of
// its children) and the jittered-disc plane test's nearest-neighbour KS within its bound (0.25: 0.224 for
// 0.223; 0.3: 0.208; without the control 0.195).
constexpr double kPlacementCrowdCount = 16.0;
// Thinning keeps a particle with a chance that falls as (its local count ratio)^this: 0 = uniform.
constexpr double kPlacementThinExponent = 2.0;
// ... and, for a particle nearer a same-class neighbour than the class's min distance, as (min distance / that
// distance)^this: large, so those go first (0 = ignore).
constexpr double kPlacementThinSpread = 8.0;
constexpr double kPlacementCrowdSlack = 0.3;
constexpr int32_t kPlacementCrowdTriangles = 8;  // fewer centroids in the disc: its expected count is nominal
constexpr double kPlacementCrowdCovered = 0.4;  // a disc expecting less than this x nominal (a corner) refuses nothing

enum class PlacementOrigin : uint8_t { seed = 0, propagated = 1, reseeded = 2, random_class = 3, filled = 4 };

struct PlacementParams {
  std::vector<float> directions;        // V x 3 per-vertex "up" field (zero vectors allowed)
  double sample_world_width = 0;        // world size of the sample's width, > 0
  std::vector<int32_t> classes;         // processing order; empty = every placeable class by count
  std::vector<int32_t> output_classes;  // rows output; empty = every class placed (see "Output classes")
  std::vector<float> vertex_scale;      // empty or V values > 0
  std::vector<float> face_density;      // empty or T values >= 0
  std::vector<float> face_probability;  // empty or T values in [0, 1]
  std::vector<float> face_size;         // empty or T values >= 0
  double size_jitter = 0;               // [0, 0.9]
  std::vector<SurfacePoint> seeds;      // optional seed points
  uint64_t seed = 0;
  int64_t max_particles = 2000000;  // >= 1; placed particles (hidden ones included)
  const std::atomic<bool>* cancel = nullptr;
  std::atomic<float>* progress = nullptr;  // 0..1 (optional)
};

struct ClassPlacementStats {
  int32_t class_id = 0;
  int64_t placed = 0;            // output rows
  int64_t hidden = 0;            // placed and propagated, not output (probability), not thinned
  int64_t thinned = 0;           // placed and propagated, hidden to bring the class to its expected count
  int64_t filled = 0;            // darts thrown to bring the class up to its expected count
  double expected = 0;           // the sample's density x the surface in sample pixels^2
  int64_t rejected_overlap = 0;  // children, seeds and darts refused by the overlap test
  int64_t crowded = 0;           // children refused by the local count control (kPlacementCrowdCount)
  int64_t walls = 0;             // children whose walk stopped short (wall, face limit, no plane)
  int64_t excluded = 0;          // landed where density or size is 0
  int64_t seeds = 0, reseeded = 0;
  int32_t reseed_rounds = 0;
  int64_t cap = 0;      // per-class cap
  bool capped = false;  // the cap stopped it
  bool random = false;  // dart throwing
};

struct PlacementStats {
  std::vector<ClassPlacementStats> classes;  // in processing order
  int32_t components = 0;                    // mesh components with area
  int64_t walks = 0;                         // normal-section walks run
  bool capped = false;                       // max_particles reached
  double seconds = 0;
};

// One row per output particle, in placement order (see the plan for each column).
struct PlacedParticles {
  std::vector<int32_t> class_id, sprite, parent, triangle;
  std::vector<double> barycentric;                   // 2 per row (b1, b2)
  std::vector<float> position, normal, sprite_axis;  // 3 per row
  std::vector<float> pixel_size, angle;
  std::vector<uint8_t> origin;  // PlacementOrigin
  PlacementStats stats;
  size_t size() const { return class_id.size(); }
};

// std::invalid_argument naming the problem for: an empty or inconsistent analysis, a walk mesh without
// area or built for another mesh, arrays of the wrong size, NaN or infinite values, scale <= 0,
// density or size < 0, probability outside 0..1, jitter outside 0..0.9, sample_world_width <= 0, a
// seed off the mesh, max_particles < 1, an unknown, repeated or background class, a class without a
// complete particle, no placeable class, an output class that is not placed or listed twice.
// texsynth::Cancelled when *cancel is raised.
PlacedParticles place_particles(const ParticleAnalysis& analysis, const SurfaceWalkMesh& mesh,
                                const PlacementParams& params);

}  // namespace texsynth
