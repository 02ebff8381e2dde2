// SPDX-License-Identifier: Apache-2.0
#include "device/setup_times.h"

#include <chrono>
#include <mutex>

namespace relief::host {

namespace {

std::mutex totals_mutex;
SetupTimes totals;
thread_local SetupTimer* innermost = nullptr;
thread_local bool ahead = false;

double now()
{
    return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

}  // namespace

SetupTimes setup_times()
{
    std::lock_guard<std::mutex> lock(totals_mutex);
    return totals;
}

SetupTimer::SetupTimer(Kind kind) : kind_(kind), start_(now()), parent_(innermost)
{
    innermost = this;
}

SetupTimer::~SetupTimer()
{
    const double total = now() - start_;
    innermost = parent_;
    if (parent_)
        parent_->children_ += total;
    std::lock_guard<std::mutex> lock(totals_mutex);
    double& sum = ahead                     ? totals.prepared
                  : kind_ == Kind::Device   ? totals.device
                  : kind_ == Kind::Programs ? totals.programs
                                            : totals.plans;
    sum += total - children_;
}

Ahead::Ahead() : was_(ahead)
{
    ahead = true;
}

Ahead::~Ahead()
{
    ahead = was_;
}

}  // namespace relief::host
