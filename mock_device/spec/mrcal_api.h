// mrcal 2.2's C header has no extern "C" guard: every C++ file includes it through here.
#pragma once

extern "C" {
#include <mrcal/mrcal.h>
}
