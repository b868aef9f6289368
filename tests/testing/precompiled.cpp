// SPDX-License-Identifier: Apache-2.0
// The translation unit that builds the tests' precompiled header (tests/CMakeLists.txt,
// IMM_TEST_PCH); it defines nothing.
