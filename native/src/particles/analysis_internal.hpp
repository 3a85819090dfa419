// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// Internal to the particle analysis: analyse_particles (analysis.cpp) runs the stages of
// analysis_segmentation.cpp, analysis_neighbours.cpp and analysis_background.cpp.
#include <array>
#include <atomic>
#include <cstdint>
#include <limits>
#include <utility>
#include <vector>

#include "texsynth/particles/analysis.hpp"

namespace texsynth {
namespace particle_detail {

constexpr int32_t kFar = std::numeric_limits<int32_t>::max() / 2;

inline int32_t wrap(int32_t v, int32_t n) {
  v %= n;
  return v < 0 ? v + n : v;
}

struct Pt {
  double x, y;
};

// Per-thread buffers of the neighbour search.
struct SearchScratch {
  std::vector<int32_t> dist, next;
  std::vector<int32_t> slot;  // per particle: index into found, -1
  struct Found {
    int32_t id, step, shift_x, shift_y;
  };
  std::vector<Found> found;  // same class
  std::vector<Found> other;  // other non-background classes (when asked for)
};

// Segmentation (analysis_segmentation.cpp).
void kmeans_classes(const std::vector<float>& colours, int32_t n, int C, int k, uint64_t seed,
                    const std::atomic<bool>* cancel, std::vector<int32_t>& labels, std::vector<float>& centres);
// merge_rims: thin components join the particle they lie against (conventions, "Rims"; k-means classes only).
void find_components(ParticleAnalysis& a, int32_t max_components, const std::atomic<bool>* cancel,
                     const std::vector<int32_t>* region, bool merge_rims);

// Touching elements (analysis_touching.cpp). lace_background: the class whose largest 8-connected piece is
// the largest (ties: lower class). split_touching: watershed regions of the non-background pixels (-1 on the
// background), each region's pixels relabelled to its most frequent class.
int32_t lace_background(const ParticleAnalysis& a, const std::atomic<bool>* cancel);
// darker_into_background: pixels of the classes darker (mean of the first 3 channels) than the background
// class relabelled to it (the shadows between touching elements).
std::vector<int32_t> split_touching(ParticleAnalysis& a, const ParticleSample& sample, double neck, double depth,
                                   double shading, const std::atomic<bool>* cancel);
void darker_into_background(ParticleAnalysis& a, const ParticleSample& sample);
void particle_geometry(const ParticleAnalysis& a, Particle& part);
// Share of the particles' outline (4-neighbour sides) that faces another particle, not the background.
double particle_contact_share(const ParticleAnalysis& a);

// Neighbours and co-occurrences (analysis_neighbours.cpp).
CoOccurrence measure_entry(const ParticleBox& p, const ParticleBox& q, double shift_x, double shift_y, int32_t neighbour);
double box_intersection(const ParticleBox& p, const ParticleBox& q, double shift_x, double shift_y);
std::vector<NeighbourHit> search_neighbours(const ParticleAnalysis& a, int32_t id, bool literal, SearchScratch& s,
                                           std::vector<NeighbourHit>* cross = nullptr);

// Density cells and background fill (analysis_background.cpp).
std::pair<int64_t, int64_t> interior_cells(const ParticleAnalysis& a, const std::atomic<bool>* cancel);
// (particles whose centroid lies at least m px inside the border, the pixels of that window), m = the
// kParticleReachPercentile of the complete particles' half bounding-box sides: a particle the border cuts
// has its true centre within m of the border, so the window counts each particle once, by where it is.
// (0, 0) when no particle is complete or the window is empty.
std::pair<int64_t, int64_t> eroded_window(const ParticleAnalysis& a);
void fill_background(ParticleAnalysis& a, const ParticleSample& s, uint64_t seed, const std::atomic<bool>* cancel);

}  // namespace particle_detail
}  // namespace texsynth
