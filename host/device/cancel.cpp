// SPDX-License-Identifier: Apache-2.0
#include "device/cancel.h"

#include <utility>

namespace relief::host {

namespace {
thread_local const std::function<bool()>* current = nullptr;
}

CancelCheck::CancelCheck(std::function<bool()> requested)
    : requested_(std::move(requested)), previous_(current)
{
    if (requested_)
        current = &requested_;
}

CancelCheck::~CancelCheck()
{
    current = previous_;
}

void stop_if_cancelled()
{
    if (current && (*current)())
        throw Cancelled();
}

}  // namespace relief::host
