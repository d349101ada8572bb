"""What the CPU can do for training, read from cpuinfo texts of real machines' kinds."""

from __future__ import annotations

from legato_drake.learning.hardware import native_bfloat16

ZEN3 = "model name\t: AMD EPYC\nflags\t\t: fpu sse2 avx avx2 fma vaes vpclmulqdq\n"
ZEN4 = ("model name\t: AMD EPYC 9R14\n"
        "flags\t\t: fpu avx avx2 avx512f avx512_bf16 avx512_vnni\n")
SAPPHIRE_RAPIDS = "flags\t\t: avx512f amx_bf16 amx_tile amx_int8\n"
NEOVERSE_V1 = "processor\t: 0\nFeatures\t: fp asimd sve bf16 i8mm\n"


def test_native_bfloat16_reads_the_flags_of_x86_and_arm():
    assert native_bfloat16(ZEN3) is False
    assert native_bfloat16(ZEN4) is True
    assert native_bfloat16(SAPPHIRE_RAPIDS) is True
    assert native_bfloat16(NEOVERSE_V1) is True
    # "avx512_bf16" is a flag of its own: a longer flag that contains it does not count
    assert native_bfloat16("flags\t: avx512_bf16x\n") is False


def test_native_bfloat16_is_unknown_without_cpuinfo_flags():
    assert native_bfloat16("") is None
    assert native_bfloat16("model name\t: Apple M2\n") is None
