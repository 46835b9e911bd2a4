// nFEX C++ client: everything (target nfex::client). See clients/cpp/README.md.
#pragma once

#include "nfex/client.hpp"
#include "nfex/context.hpp"
#include "nfex/errors.hpp"
#include "nfex/opencv.hpp"
#include "nfex/selection.hpp"
#include "nfex/session.hpp"
