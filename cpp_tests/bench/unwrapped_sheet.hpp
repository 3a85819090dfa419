// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// The benchmarks' ~70k-triangle UV-unwrapped mesh: a bumpy 187x187-quad sheet cut into 4x4 islands,
// every other island mirrored, packed into the unit square with gaps (Blender loop triangles).
#include <array>
#include <cmath>
#include <cstdint>
#include <vector>

namespace bench {

struct UnwrappedSheet {
  std::vector<float> positions, uvs;
  std::vector<int32_t> triangles;
};

inline const UnwrappedSheet& unwrapped_sheet() {
  static UnwrappedSheet s = [] {
    UnwrappedSheet m;
    const int n = 187, blocks = 4;  // 2 * 187^2 = 69,938 triangles
    for (int j = 0; j <= n; ++j)
      for (int i = 0; i <= n; ++i) {
        const double x = double(i) / n, y = double(j) / n;
        m.positions.insert(m.positions.end(),
                           {float(x), float(y), float(0.05 * std::sin(9 * x) * std::cos(7 * y))});
      }
    // Island (bi, bj) holds quads [bi*n/blocks, (bi+1)*n/blocks) x ...; its UVs are the sheet's,
    // scaled into a cell of the 4x4 atlas with a 4 % gap, mirrored in u when bi + bj is odd.
    auto block = [&](int q) { return q * blocks / n; };
    auto uv = [&](int i, int j, int bi, int bj) {
      const double cell = 1.0 / blocks, gap = 0.04 * cell, scale = (cell - 2 * gap) * blocks / n;
      double lu = (i - double(bi) * n / blocks) * scale, lv = (j - double(bj) * n / blocks) * scale;
      if ((bi + bj) % 2) lu = (cell - 2 * gap) - lu;
      return std::array<float, 2>{float(bi * cell + gap + lu), float(bj * cell + gap + lv)};
    };
    auto id = [&](int i, int j) { return int32_t(j * (n + 1) + i); };
    for (int j = 0; j < n; ++j)
      for (int i = 0; i < n; ++i) {
        const int bi = block(i), bj = block(j);
        const int c[4][2] = {{i, j}, {i + 1, j}, {i + 1, j + 1}, {i, j + 1}};
        static const int split[2][3] = {{0, 1, 2}, {0, 2, 3}};
        for (const auto& tri : split)
          for (int k = 0; k < 3; ++k) {
            m.triangles.push_back(id(c[tri[k]][0], c[tri[k]][1]));
            const auto t = uv(c[tri[k]][0], c[tri[k]][1], bi, bj);
            m.uvs.insert(m.uvs.end(), t.begin(), t.end());
          }
      }
    return m;
  }();
  return s;
}

}  // namespace bench
