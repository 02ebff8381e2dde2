// SPDX-License-Identifier: Apache-2.0
#pragma once
// Where a process's compute set-up time goes (opening the device, building
// programs, planning FFTs): the cost a batch pays once and a map-per-process
// farm pays per map. `relief -v` prints it per step.
namespace relief::host {

struct SetupTimes {
    double device = 0.0;    // seconds: platforms, device choice, context and queue
    double programs = 0.0;  // relief's own kernel builds (PoCL's cache makes repeats cheap)
    double plans = 0.0;     // FFT/DCT plans, VkFFT's kernel generation and builds
    double prepared = 0.0;  // all of the above done by threads marked Ahead (prepare_height)
};

// Totals since the process started, over all threads (a thread marked Ahead
// adds to `prepared` only).
SetupTimes setup_times();

// While it lives, this thread's set-up counts as done ahead (`prepared`).
class Ahead {
public:
    Ahead();
    ~Ahead();
    Ahead(const Ahead&) = delete;
    Ahead& operator=(const Ahead&) = delete;

private:
    bool was_;
};

// Adds its lifetime to one total. Nested timers are not counted twice: a
// program built while planning an FFT counts as the program's, the rest as
// the plan's.
class SetupTimer {
public:
    enum class Kind { Device, Programs, Plans };
    explicit SetupTimer(Kind kind);
    ~SetupTimer();
    SetupTimer(const SetupTimer&) = delete;
    SetupTimer& operator=(const SetupTimer&) = delete;

private:
    Kind kind_;
    double start_;
    double children_ = 0.0;
    SetupTimer* parent_;
};

}  // namespace relief::host
