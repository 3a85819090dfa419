// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// Texture particles, analysis half (Dischler et al. 2002, §2.1-2.2; docs/algorithms/texture_particles.md,
// "Analysis"): segmentation into classes, particles (8-connected components), their boxes and completeness,
// co-occurrence lists, per-class tables, the filled background and soft sprites.
//
// Conventions.
//  - Sample: height x width x channels floats (3 or 4), interleaved, row y = 0 at the BOTTOM. Pixel
//    (x, y) covers [x, x + 1) x [y, y + 1); its centre is (x + 0.5, y + 0.5). Not necessarily square.
//  - Segmentation: Gaussian blur (sigma px, borders clamp, or wrap when tileable and wrap_blur), then k-means++ on
//    the blurred colours (all channels, stored values) fitted on a seeded subsample of <= 65,536
//    pixels, 20 Lloyd iterations, every pixel then assigned once. Classes are numbered by decreasing
//    pixel count. Or an artist's label image (class >= 0 per pixel) replaces blur and k-means.
//  - Background class: the class with the most pixels unless given. Its pixels are no particles.
//  - Particles: 8-connected components of the other classes (wrapping around when tileable).
//    Components below min_area, and beyond max_components (the smallest first), are merged into the
//    background class (their pixels' labels change). Ids follow the first pixel in row-major order.
//  - Coordinates of a particle (centroid, bbox, box) are unwrapped: on tileable samples a component
//    that crosses an edge keeps contiguous coordinates that may leave [0, W) x [0, H) (the pixel is
//    then (x mod W, y mod H)); its centroid is always inside the sample.
//  - Box: PCA of the pixel centres; oriented along the principal axis when the eigenvalue ratio is
//    >= 1.5, else axis-aligned (angle 0). Extents hold every pixel square. Angle in (-pi/2, pi/2].
//  - Complete: at most 10 % of the boundary pixels (mask pixels with a 4-neighbour outside the mask or
//    outside the image) lie on the image border. Tileable samples: always complete.
//  - Co-occurrences, for each complete particle P of a non-background class: same-class neighbours
//    (complete or not) by least Chebyshev distance between the masks (= the step at which repeated
//    3x3 dilation of P first touches them), within min(1.5 x max(box width, height), min(W, H) / 4)
//    steps. In P's box frame (x along its axis) the neighbour's quadrant comes from the signs of the
//    box-centre offset (|offset| < 0.5 px counts as +): 0 = (+,+), 1 = (-,+), 2 = (-,-), 3 = (+,-).
//    Per quadrant, the neighbours at its least distance are kept, at most 2 (nearest centres first,
//    then lower id). Entry (dx, dy) = signed gaps between P's and the neighbour's extents along P's
//    x and y axes on the quadrant's side (negative = overlap along that axis): the neighbour's near
//    edges lie at P's far edges + (dx, dy). angle = neighbour box angle - P's, in (-pi/2, pi/2]; towards an
//    incomplete neighbour (its box is that of its visible part) the class's median angle towards complete
//    neighbours in that quadrant, 0 when there is none.
//  - Empty quadrants (texture_particles.md, "Analysis"): the opposite quadrant's entries (point reflection:
//    same dx, dy, angle); when it is empty too, the class-wide median of the measured entries of that
//    quadrant; else the x-flipped adjacent quadrant (q ^ 1), else the y-flipped one (3 - q) (angle
//    negated).
//  - Classes with 1-3 particles are "random", and so are scattered classes (fewer than half of their
//    complete particles' quadrants have a measured neighbour): min distance = 0.7 x the mean
//    nearest-neighbour centre distance (one particle: 0.7 x min(W, H)); filled in for every class.
//    Overlap tolerance = 95th percentile of the observed box overlaps (intersection / smaller box area,
//    over co-occurring pairs that overlap) + 0.05, 0.1 if none, capped at 0.5.
//  - Density (particles per px^2, every class; issue 30): particles / (W x H) counts a particle the border
//    cuts as a whole one (crops of a random field of 20 x 13 px pebbles, 60 per 256^2: 1.08-1.18 x the
//    field's density) and a sample drawn with an empty margin as emptier than its arrangement (a 6 x 6 grid
//    of 28 px cells inside 14 px margins: 1 / 982 px^2 for the lattice's 1 / 784). So, on samples that are
//    not tileable: blobs = 8-connected groups of particle pixels of any class; each pixel goes to the blob
//    nearest it (chessboard distance); the cells that touch the image border are left out, and the total
//    density = the particles in the interior cells / their pixels, when there are at least
//    kParticleDensityCells of them (else, and on tileable samples, particles / (W x H)). Crops of the
//    pebble field: 1.02-1.06 x its density. Cells only hold for separate elements: touching ones (cobbles,
//    gravel, leaf litter) join into blobs that reach the border, and the few small cells left inside
//    overstate the density (the corpus' cobbles 3.6 x, generated packed pebbles 2.6 x). So a second
//    estimate: the particles whose centroid lies in the window eroded by m / its pixels, m = the
//    kParticleReachPercentile of the complete particles' half bounding-box sides (a cut particle's true
//    centre lies within m of the border); on the 12 element-like corpus samples 0.77-1.09 x particles /
//    (W x H), which counts cut particles whole; with fewer than kParticleDensityWindow particles in the window,
//    particles / (W x H) is kept. The cells' figure is kept when it lies within
//    kParticleDensityAgreement of the window's (the lattice above: 1 / 784 against 1 / 860), else the
//    window's. Blobs, not particles: a particle nested in another (a halo
//    ring k-means makes around a pebble's core) shares its cell (cells per particle counted 201 particles
//    per 256^2 for 162). A class's density = the total x its share of the particles, an incomplete one
//    counting kParticleIncompleteWeight (the border cuts large particles more often than small ones).
//    Shares from cells per class (4 x larger with 4 classes, fewer interior) came out up to 13 % off the
//    counts of 15-particle classes, and from each class's particles in the interior cells up to 24 %.
//  - Class pairs (issue 30; the paper tests a new particle against all particles placed so far): for
//    every pair of classes (k, j), symmetric, k x j in class_pairs. Off the diagonal, the nearest class-j
//    particles of each complete class-k particle are found in the same window as its co-occurrences (least
//    Chebyshev distance between the masks, at most 2, nearest centres first), both directions pooled:
//    tolerance = 95th percentile of the box overlaps (intersection / smaller box, 0 when apart) of the
//    distinct pairs + 0.01, 0.1 when no pair was measured, capped at 1 (a class inside another's boxes is
//    what some samples show). Over all pairs, not only the overlapping ones as within a class: pebbles 4 px
//    apart whose turned boxes overlap in 3 % of the pairs, by 0.007 at most, got 0.057 that way, and 24 %
//    of the placed pebbles then overlapped one of the other class;
//    margin = half the 10th percentile of their box gaps max(dx, dy) (px, >= 0: overlapping pairs give 0).
//    On the diagonal: the class's tolerance, and half the 10th percentile of max(dx, dy) over its measured
//    co-occurrences. pairs = distinct particle pairs measured.
//  - Rims (issue 30, texture_particles.md "Rims"; k-means classes only, never an artist's label image): with
//    blur, k-means also classes the band of in-between colour at an element's edge, which then rings the
//    element's core as a particle of its own (the pebble field: 117-169 particles for 60 pebbles).
//    After the 8-connected components, a component of thickness t <= kParticleRimDepth (t: the 4-neighbour
//    erosions after which at most kParticleRimInterior of its pixels remain) joins the particle of larger t
//    that takes the most of its outline sides (4-neighbour, the background counted) when that share is
//    >= kParticleRimContact, >= kParticleRimHug of its pixels lie within 2 x kParticleRimDepth steps inside
//    it of that particle, and its k-means centre lies within kParticleRimColour x |h - g| of the segment from
//    the particle's class centre h to the background's g. Up to kParticleRimRounds rounds (a rim of a rim);
//    a joined rim takes its host's class in labels and its frame in unwrapped / pixel_xy (tileable). Areas
//    for min_area and the component cap are those after joining.
//  - Touching elements (params.touching; issue 30, texture_particles.md "Touching elements"): the background
//    class is, unless given, the class whose largest 8-connected piece is the largest (the gaps' lace between
//    stones, not the stones when they cover most of the sample); with touching_darker (and the background
//    automatic) the pixels of the classes darker than it (mean of the first 3 channels) join it, the shadows
//    between touching elements, when some class is lighter than it (else the elements are dark on a light
//    ground and nothing joins). The other pixels, all classes together, are
//    split by a watershed of their chamfer (5-7) distance to the background (wrapped when tileable; the image
//    border is no background): flooded from the top by decreasing distance, a pixel joins the basin of its
//    highest flooded neighbour; two basins that meet merge unless the lower peak rises >= 1.5 px above the
//    saddle and the saddle is <= touching_neck x that peak (with touching_shading s > 0 the relief is the
//    distance x (1 - s + s x min(1, brightness / the foreground's mean brightness))). Basins whose peak is below kParticleTouchingThin x
//    the median peak (that of the basin holding the median foreground pixel by peak) go to the background (a
//    shadow strip, a bit of rim). Each basin takes its most frequent class; the particles are then the
//    8-connected components within one basin. Not always on: it changes separated samples too
//    (texture_particles.md, "Touching elements"). touching_auto tries it only where a plain particle covers
//    more than kParticleTouchingAutoSpan of the sample, or where the plain particles face each other along
//    at least kParticleTouchingAutoContact of their outlines and the split makes their sizes more than twice
//    as uniform (sd of log area < kParticleTouchingAutoUniform x the plain one's: the plain particles were
//    fragments, as leaves cut by veins of another colour into strips), and keeps the
//    plain components when the split leaves a smaller share of complete particles (elements cut by a
//    non-tileable border); a.touching says which, a.touching_fragments that the sizes decided.
//  - Background fill: the sample with every particle dilated by 2 px (3x3 twice) filled by onion
//    peeling: each unknown pixel with known 8-neighbours copies one of them, chosen by a seeded hash.
//
// Results are identical for a seed at any thread count: parallel passes write per-row or
// per-particle results only, and every sum runs in a fixed order.
#include <array>
#include <atomic>
#include <cstddef>
#include <cstdint>
#include <vector>

namespace texsynth {

constexpr int kParticleMinClasses = 2;
constexpr int kParticleMaxClasses = 12;
constexpr int kParticleMaxLabelClasses = 256;   // artist label images
constexpr int kParticleMinSide = 8;
constexpr int64_t kParticleMaxPixels = int64_t(1) << 28;
constexpr int kParticleKMeansIterations = 20;
constexpr int kParticleKMeansSubsample = 65536;
constexpr int32_t kParticleMaxComponents = 20000;
constexpr double kParticleIncompleteFraction = 0.10;
constexpr double kParticleOrientedRatio = 1.5;
constexpr double kParticleDilationFactor = 1.5;
constexpr int kParticleMaxPerQuadrant = 2;
constexpr int kParticleHalo = 2;  // background-fill dilation and sprite alpha ramp, px
// A class is scattered (placed at random) when fewer than this share of its complete particles'
// quadrants found a neighbour within the dilation cap (lattices 0.98-1.00, scattered berries 0.28).
constexpr double kParticleScatteredFraction = 0.5;
// Class pairs: percentile of the nearest box gaps whose half is the exclusion margin, and the cap of the
// overlap tolerance between two classes.
constexpr double kParticleGapPercentile = 0.10;
constexpr double kParticleCrossToleranceCap = 1.0;
constexpr double kParticleCrossSlack = 0.01;  // added to the 95th-percentile overlap of two classes
// Density from the blobs' cells when at least this many particles lie in cells that do not touch the border.
constexpr int32_t kParticleDensityCells = 8;
constexpr double kParticleDensityAgreement = 1.25;  // cells are trusted within this factor of the eroded window
// The eroded window is used from this many particles on (Poisson noise about 20 %; fewer: particles / (W x H),
// 17 coffee beans of 64^2 in the window read 1.18 x the count, 8 cups of 1536^2 0.65 x).
constexpr int32_t kParticleDensityWindow = 24;
constexpr double kParticleReachPercentile = 0.9;   // eroded_window's margin
constexpr double kParticleIncompleteWeight = 0.5;  // an incomplete particle's weight in its class's share
// Rims (conventions, "Rims"; k-means classes only): a component whose pixels all but
// kParticleRimInterior erode away within kParticleRimDepth 4-neighbour erosions (a band <= ~4 px wide)...
constexpr double kParticleRimInterior = 0.1;
constexpr int kParticleRimDepth = 2;
// ...joins the thicker particle that takes the largest share of its outline sides, when that share is at
// least this...
constexpr double kParticleRimContact = 0.25;
// ...at least this share of its pixels lies within 2 x kParticleRimDepth steps (inside it) of that particle...
constexpr double kParticleRimHug = 0.9;
// ...and its k-means colour lies within this x |particle - ground| of the segment between the two (a mix).
constexpr double kParticleRimColour = 0.25;
constexpr int kParticleRimRounds = 16;  // a rim of a rim of ... (layers of blurred edge)
// Touching elements: two watershed basins stay apart when the saddle between them is at most this share of
// the lower one's peak distance (and >= 1.5 px below it).
constexpr double kParticleTouchingNeck = 0.85;
// Touching elements: two basins merge when the lower peak rises less than this (px) above their saddle.
constexpr double kParticleTouchingDepth = 1.5;
// Touching elements: regions whose peak distance is below this share of the median region's go to the background.
constexpr double kParticleTouchingThin = 0.35;
// Touching elements, automatic: the split is tried when one particle covers more than this share of the sample.
constexpr double kParticleTouchingAutoSpan = 0.2;
// Touching elements, automatic: without a spanning region the split is also tried where at least this share
// of the plain particles' outline faces another particle (pieces of one element lie against each other)...
constexpr double kParticleTouchingAutoContact = 0.6;
// ...and kept when it makes the particle sizes this much more uniform (standard deviation of log area, split <
// this x plain): the plain components were fragments of elements.
constexpr double kParticleTouchingAutoUniform = 0.5;

// Borrowed sample pixels (see conventions).
struct ParticleSample {
  const float* pixels = nullptr;
  int32_t width = 0, height = 0, channels = 0;
};

struct ParticleAnalysisParams {
  int classes = 4;             // k-means k, 2..12 (ignored with labels)
  double blur_sigma = 1.0;     // px, 0..32; 0 = no blur (ignored with labels)
  int32_t min_area = 0;        // px; 0 = max(16, 0.02 % of the sample); >= 1 otherwise
  std::vector<int32_t> labels; // empty = k-means; else width*height classes >= 0 (< 256), row 0 bottom
  int32_t background = -1;     // background class; -1 = the class with the most pixels
  bool tileable = false;
  // With tileable: the blur wraps across the border too. false keeps the segmentation of an untiled analysis
  // (the add-on's detected repeat: k-means from one start is tipped by the border's few pixels).
  bool wrap_blur = true;
  uint64_t seed = 0;
  int32_t max_components = kParticleMaxComponents;  // >= 1
  // K-means classes: thin bands of in-between colour join the element they ring (conventions, "Rims"); false
  // only to measure them (the benchmark's baseline). Never with labels.
  bool join_rims = true;
  // Touching elements (conventions, "Touching elements"): background = the lace class (unless given), the
  // other pixels split by a distance-transform watershed; neck in (0, 1] (kParticleTouchingNeck).
  bool touching = false;
  // Automatic: the plain components first; the split above where one particle covers more than
  // kParticleTouchingAutoSpan of the sample, or where the particles touch each other
  // (kParticleTouchingAutoContact) and the split makes their sizes more uniform (kParticleTouchingAutoUniform);
  // kept unless its share of complete particles is smaller.
  bool touching_auto = false;
  double touching_neck = kParticleTouchingNeck;
  double touching_depth = kParticleTouchingDepth;  // px, >= 0: a lower peak this little above the saddle merges
  bool touching_darker = true;  // classes darker than the automatic background join it
  double touching_shading = 0;   // 0..1: weight of the sample's darkness in the watershed's relief (0 = distance)
  const std::atomic<bool>* cancel = nullptr;
  std::atomic<float>* progress = nullptr;  // 0..1 while the call runs (optional)
};

struct ParticleBox {
  float cx = 0, cy = 0;          // centre
  float angle = 0;               // radians, axis = (cos, sin), in (-pi/2, pi/2]
  float half_x = 0, half_y = 0;  // half extents along the axis and its perpendicular
};

struct Particle {
  int32_t id = 0, class_id = 0, area = 0;
  float centroid_x = 0, centroid_y = 0;  // mean of the pixel centres
  int32_t x0 = 0, y0 = 0, x1 = 0, y1 = 0;  // inclusive pixel bounding box (unwrapped)
  ParticleBox box;
  int32_t boundary_pixels = 0, border_pixels = 0;
  bool complete = false;
};

enum class EntrySource : uint8_t { kMeasured = 0, kOpposite = 1, kClassMedian = 2, kAdjacent = 3 };

struct CoOccurrence {
  int32_t quadrant = 0;
  float dx = 0, dy = 0, angle = 0;
  int32_t neighbour = -1;  // particle id; -1 for class-median entries
  EntrySource source = EntrySource::kMeasured;
};

struct ParticleClass {
  int32_t pixels = 0, particles = 0, complete = 0;
  std::array<float, 4> colour{};  // mean sample colour of its pixels (channels used)
  bool background = false;
  bool has_complete = false;      // false for a class with particles but no complete one
  bool random = false;            // 1-3 particles, or scattered (kParticleScatteredFraction)
  double density = 0;             // particles per px^2 (conventions, "Density")
  double min_distance = 0;        // 0.7 x mean nearest-neighbour centre distance (see conventions)
  double tolerance = 0.1;         // overlap tolerance
};

// What the sample shows between the particles of two classes (conventions, "Class pairs").
struct ParticleClassPair {
  int32_t pairs = 0;       // distinct particle pairs measured
  double tolerance = 0.1;  // overlap tolerance (intersection / smaller box)
  double margin = 0;       // px, >= 0: half the 10th-percentile nearest box gap
};

struct ParticleAnalysisStats {
  double seconds_blur = 0, seconds_kmeans = 0, seconds_components = 0, seconds_geometry = 0,
         seconds_cooccurrence = 0, seconds_background = 0, seconds_total = 0;
};

struct ParticleAnalysis {
  int32_t width = 0, height = 0, channels = 0;
  bool tileable = false;
  bool touching = false;  // the touching split made the particles (asked for, or chosen by touching_auto)
  bool touching_fragments = false;  // touching_auto kept the split because the plain particles were fragments
  int32_t num_classes = 0, background = 0, min_area = 0;
  std::vector<float> centres;        // k-means centres, num_classes x channels (empty with labels)
  std::vector<int32_t> labels;       // class per pixel, after merges
  std::vector<int32_t> components;   // particle id per pixel, -1 = background
  std::vector<int32_t> unwrapped;    // tileable only: 2 per pixel, its particle's (x, y)
  std::vector<Particle> particles;
  std::vector<int64_t> pixel_start;  // CSR over particles: pixel_xy[2 * pixel_start[i] ...]
  std::vector<int32_t> pixel_xy;     // unwrapped (x, y) of each particle's pixels
  std::vector<int32_t> cooc_start;   // CSR over particles (n + 1); incomplete/background: empty
  std::vector<CoOccurrence> cooc;
  std::vector<ParticleClass> classes;
  std::vector<ParticleClassPair> class_pairs;  // num_classes x num_classes, symmetric: row k, column j
  std::vector<float> background_fill;  // height x width x channels
  int32_t merged_small = 0, merged_over_cap = 0;
  int32_t classes_without_complete = 0;  // classes with particles, none complete
  ParticleAnalysisStats stats;

  int32_t merged_components() const { return merged_small + merged_over_cap; }
  const ParticleClassPair& class_pair(int32_t k, int32_t j) const {
    return class_pairs[std::size_t(k) * std::size_t(num_classes) + std::size_t(j)];
  }
};

// Throws std::invalid_argument (naming the problem) for: null pixels, channels not 3 or 4, a side
// below 8 px or more than 2^28 pixels, NaN/inf pixels, classes outside 2..12, blur outside 0..32,
// negative min_area, max_components < 1, labels of the wrong size or outside 0..255, a background
// class out of range; texsynth::Cancelled when *cancel is raised.
ParticleAnalysis analyse_particles(const ParticleSample& sample, const ParticleAnalysisParams& params);

// One kept neighbour of a particle (conventions, "Co-occurrences").
struct NeighbourHit {
  int32_t neighbour = -1, quadrant = 0, step = 0;
  int32_t shift_x = 0, shift_y = 0;  // tileable: the neighbour copy hit is its unwrapped place + shift
};

// The kept neighbours of particle `id`, by quadrant then rank. literal_dilation = true grows the mask
// by 3x3 dilation step by step (the paper's procedure; the baseline) instead of one chessboard
// distance transform; both give the same hits. Empty for background ids; std::invalid_argument for an
// id out of range.
std::vector<NeighbourHit> particle_neighbours(const ParticleAnalysis& analysis, int32_t id,
                                              bool literal_dilation = false);

// Soft sprite (texture_particles.md, "Analysis"): the particle's bounding box + 2 px, straight RGBA.
// Colour from the sample (wrapped when tileable, clamped at the edges otherwise); alpha 1 on the mask,
// else max(0, 1 - d / 3) with d the distance to the nearest mask pixel centre (2/3 and 1/3 on the two
// rings, 0 beyond 2 px). Alpha of a 4-channel sample is not used.
struct ParticleSprite {
  int32_t x0 = 0, y0 = 0;           // unwrapped sample position of the sprite's pixel (0, 0)
  int32_t width = 0, height = 0;
  std::vector<float> rgba;          // height x width x 4, row 0 at the bottom
};
// std::invalid_argument for an id out of range or a sample of another size/channel count.
ParticleSprite particle_sprite(const ParticleAnalysis& analysis, const ParticleSample& sample, int32_t id);

}  // namespace texsynth
