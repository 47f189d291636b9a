// A prepared dataset of random motion in the H3.6M layout, for measuring and
// testing where the cost or the check does not depend on real motion (the
// benchmark, the CUDA-graph comparison) and H3.6M may be absent.
//
// Thread safety: a pure function.
#pragma once

#include "format/prepared_dataset.h"

namespace mm {

// Four training sequences (subject S1) of 600 frames of standard-normal
// values in the 51 kept columns of H3.6M, under an identity normalisation;
// the same for the same seed.
PreparedDataset synthetic_h36m_dataset(unsigned seed = 7);

}  // namespace mm
