// SPDX-License-Identifier: Apache-2.0
// Heights are defined up to a constant; relief's have zero mean, and so do
// the golden models' and the tests' exact fields before they are compared.
#pragma once
#include <vector>

namespace relief::reference {

inline void subtract_mean(std::vector<double>& v)
{
    if (v.empty())
        return;
    double mean = 0.0;
    for (double x : v)
        mean += x;
    mean /= double(v.size());
    for (double& x : v)
        x -= mean;
}

}  // namespace relief::reference
