// nFEX C++ client: the context E a client sends — condition dimension → value (agent, motion, scene,
// light, reflectance, texture; also budget_ms and compute). Names and values come from the graph
// (GET /v1/vocabulary); the service rejects unknown ones with the allowed values (Unprocessable).
#pragma once

#include <map>
#include <string>

namespace nfex {

using Context = std::map<std::string, std::string>;

/// "agent=car,scene=outdoor" → {agent: car, scene: outdoor}; spaces around names and values are
/// dropped. Throws std::invalid_argument naming the item that is not name=value.
Context parse_context(const std::string& text);

}  // namespace nfex
