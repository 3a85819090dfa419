// SPDX-License-Identifier: GPL-3.0-or-later
// Keeps texsynth_core non-empty before the first module lands; remove once others exist.
namespace texsynth { int core_placeholder() { return 0; } }
