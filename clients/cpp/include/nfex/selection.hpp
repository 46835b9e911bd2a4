// nFEX C++ client: the Selection the service answers (POST /v1/select, session frames), typed.
// Field names follow the service's JSON (docs/service.md, nfex_core/advisor/selection.py): the
// extractor α, its parameters Θ′ (OpenCV argument names), how to build it, the candidates with their
// scores, what was pruned and why, the context given or estimated, versions, budget and warnings.
#pragma once

#include <nlohmann/json.hpp>

#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <variant>
#include <vector>

namespace nfex {

/// One parameter value: the graph's datatypes xsd:boolean, xsd:integer, xsd:double.
using Value = std::variant<bool, std::int64_t, double>;
/// Parameters by OpenCV argument name (Θ).
using Params = std::map<std::string, Value>;

double to_double(const Value& v);
Value value_from_json(const nlohmann::json& j);
nlohmann::json to_json(const Params& params);

/// A rule that shaped a decision: its IRI, label, the human reason, and its kind
/// (sparql, prune, adjust, weight, prefer, require, budget, shape).
struct Citation {
    std::string rule, label, reason, kind;
    std::optional<std::string> source;
};

/// A parameter a rule changed: from, to, by which factor, whether it was clamped to its range.
struct Adjustment {
    std::string parameter;
    Value from, to;
    double factor = 1.0;
    bool clamped = false;
    std::vector<Citation> because;
};

/// A candidate extractor that survived pruning, with its score on the frame (F_metrics + H·A).
struct Candidate {
    std::string extractor;
    std::optional<double> score;
    double bonus = 0.0;
    std::map<std::string, double> metrics;  // m1…m7 on the frame
    Params params;
    std::vector<Adjustment> adjustments;
    std::optional<int> keypoints;
    std::optional<double> extraction_ms;
    nlohmann::json evidence;  // the measurements behind the candidate's accuracy term
};

/// A pruned extractor and the rules that pruned it.
struct Pruned {
    std::string extractor;
    std::vector<Citation> because;
};

/// One dimension of the context E: its value and whether it was given, estimated or unknown.
struct ContextEntry {
    std::string dimension;
    std::optional<std::string> value;
    std::string source;
    std::optional<double> confidence;
    std::optional<std::string> evidence;
};

/// Spread the detected keypoints over square cells of cell_size px, keeping `keep` (0: all).
struct Grid {
    int cell_size = 0;
    int keep = 0;
};

/// How to build α with Θ′: the OpenCV constructor (a cv2 path such as "ORB_create" or
/// "xfeatures2d.AKAZE_create"), the matching norm ("NORM_HAMMING"…), the constructor's arguments and
/// the grid spread to apply, if any.
struct OpenCVRecipe {
    std::string constructor, norm;
    Params args;
    std::optional<Grid> grid;
};

/// The per-frame extraction budget in force.
struct Budget {
    double ms = 0.0;
    std::string source, compute;
    double factor = 1.0;
    int width = 0, height = 0;
    std::string size_source;
};

struct Versions {
    long long graph = 0;          // the graph version the answer was computed on
    nlohmann::json programs;      // DSL program name → version
    int rules = 0;                // SPARQL rules in force
    nlohmann::json model;         // the neural models used, if any
};

/// Where a session frame stands in its stream.
struct StreamPosition {
    std::string id;
    int frame = 0;
    bool temporal = false;  // whether a previous frame's state was used
};

struct Selection {
    std::string extractor;  // α*
    Params params;          // Θ′
    OpenCVRecipe opencv;
    std::string mode;       // "prior" (no frame), "metrics", "selectornet"
    std::vector<Candidate> candidates;  // best first
    std::vector<Pruned> pruned;
    std::vector<ContextEntry> context;
    nlohmann::json weights;  // metric → {value, because}
    std::optional<Budget> budget;
    std::vector<std::string> warnings;
    Versions versions;
    std::map<std::string, double> timings_ms;
    std::optional<StreamPosition> session;  // set on session frames
    nlohmann::json raw;                     // the answer as received

    /// Throws ProtocolError when the document is not a Selection.
    static Selection from_json(const nlohmann::json& doc);
};

}  // namespace nfex
