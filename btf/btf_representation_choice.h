// The choice of representation and rank in CompressBtf: the representations
// the options allow, the rank a spectrum gives under the budget, and which
// of two candidates is the better pick. Internal to btf/.
#pragma once

#include <string>
#include <vector>

#include "btf/btf_compression.h"
#include "btf/btf_factorization.h"
#include "core/btf.h"

namespace mesocap::btf::compression {

// The representations allowed: every layout and colour the options leave
// open, the clustered layout at each cluster count; rgb first, whose
// spectra settle their errors, so that a ycbcr representation that cannot
// beat the best of them need not be built.
std::vector<BtfRepresentationCandidate> AllowedRepresentations(const BtfCompressionOptions& options);

// Whether candidate c meets the budget; under an error budget, factors as
// large as the BTF itself (full_bytes) compress nothing: they do not count as
// meeting it, and c's note says so.
void JudgeAgainstBudget(const BtfCompressionOptions& options, long long full_bytes, BtfRepresentationCandidate& c);

// The rank of the factorization from a spectrum's report `r`: as requested
// (at most the matrix's), or the smallest whose spectrum error meets the
// budget; says why in *reason.
int ChooseRank(const BtfCompressionOptions& options, core::BtfFactorColor color, const BtfCompressionReport& r,
               std::string* reason);

// Builds the factors at the rank the options give or the spectrum chooses,
// measures their RGB error, and fills in the rank and bytes. The budget is on
// RGB values; for ycbcr the spectrum measures the error in the factored
// space, so the rank grows until the measured RGB error fits (for rgb only
// float rounding could make it grow).
core::FactoredBtf BuildAtChosenRank(core::FullBtfReader& btf, const BtfCompressionOptions& options,
                                    const Factorization& f, BtfCompressionReport& r);

// Whether candidate c is a better pick than the best so far: with a byte
// budget the more accurate; with an error budget the smaller of those that
// meet it, else (none meets it) the more accurate.
bool Better(const BtfRepresentationCandidate& c, const BtfRepresentationCandidate& best, bool byte_budget);

}  // namespace mesocap::btf::compression
