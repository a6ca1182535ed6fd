// The bearer token's comparison (wire::TokensEqual): a wrong token must take as long to refuse
// as the right one takes to accept, wherever it first differs, so that timing the daemon's
// UNAUTHENTICATED answers tells nothing about the token. The three cases' times should agree
// within the noise. Run: build-*/tests/bench/transient_bench --benchmark_filter=TokensEqual
#include <benchmark/benchmark.h>

#include <string>

#include "transient/wire/credentials.h"

namespace transient {
namespace {

// 64 hex digits, as `openssl rand -hex 32` makes.
const std::string kToken(64, 'a');

std::string Given(int64_t differs_at) {
  std::string given = kToken;
  if (differs_at >= 0) given[static_cast<size_t>(differs_at)] = 'b';
  return given;
}

// Argument: where the given token first differs (-1: nowhere, it is right).
void BM_TokensEqual(benchmark::State& state) {
  const std::string given = Given(state.range(0));
  state.SetLabel(state.range(0) < 0 ? "right token"
                                    : "wrong at byte " + std::to_string(state.range(0)));
  for (auto _ : state) {
    benchmark::DoNotOptimize(wire::TokensEqual(given, kToken));
  }
}
BENCHMARK(BM_TokensEqual)->Arg(-1)->Arg(0)->Arg(63);

}  // namespace
}  // namespace transient
