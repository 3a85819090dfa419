// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// The one place that knows Embree 3 from Embree 4 (CMake defines TEXSYNTH_EMBREE_MAJOR):
// the header moved, and rtcIntersect1 lost its RTCIntersectContext argument in 4.
#if TEXSYNTH_EMBREE_MAJOR >= 4
#include <embree4/rtcore.h>
#else
#include <embree3/rtcore.h>
#endif

namespace texsynth::embree {

// Closest hit of one ray, no filters, all geometry masks.
inline void intersect1(RTCScene scene, RTCRayHit& ray_hit) {
#if TEXSYNTH_EMBREE_MAJOR >= 4
  rtcIntersect1(scene, &ray_hit);
#else
  RTCIntersectContext context;
  rtcInitIntersectContext(&context);
  rtcIntersect1(scene, &context, &ray_hit);
#endif
}

}  // namespace texsynth::embree
