/* SPDX-License-Identifier: GPL-3.0-or-later */
/* Forced into every translation unit of the self-contained build (TEXSYNTH_SELF_CONTAINED), Embree's too.
   glibc 2.29 gave exp, exp2, log, log2 and pow new symbol versions that only drop the SVID errno
   wrapper; the values are the same and TexSynth never reads errno after them. Binding to the
   GLIBC_2.2.5 versions keeps the module loadable on glibc 2.28 (manylinux_2_28). */
#ifndef TEXSYNTH_GLIBC_2_28_FLOOR_H
#define TEXSYNTH_GLIBC_2_28_FLOOR_H
#if defined(__x86_64__) && defined(__linux__)
__asm__(".symver exp,exp@GLIBC_2.2.5");
__asm__(".symver exp2,exp2@GLIBC_2.2.5");
__asm__(".symver log,log@GLIBC_2.2.5");
__asm__(".symver log2,log2@GLIBC_2.2.5");
__asm__(".symver pow,pow@GLIBC_2.2.5");
#endif
#endif
