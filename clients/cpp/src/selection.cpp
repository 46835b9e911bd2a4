#include "nfex/selection.hpp"

#include "nfex/errors.hpp"

namespace nfex {

using nlohmann::json;

double to_double(const Value& v) {
    return std::visit([](auto x) { return static_cast<double>(x); }, v);
}

Value value_from_json(const json& j) {
    if (j.is_boolean()) return j.get<bool>();
    if (j.is_number_integer()) return j.get<std::int64_t>();
    if (j.is_number_float()) return j.get<double>();
    throw ProtocolError("a parameter value must be a boolean or a number, got " + j.dump());
}

json to_json(const Params& params) {
    json out = json::object();
    for (const auto& [name, v] : params) std::visit([&, &name = name](auto x) { out[name] = x; }, v);
    return out;
}

namespace {

template <class T>
std::optional<T> opt(const json& doc, const char* key) {
    auto it = doc.find(key);
    if (it == doc.end() || it->is_null()) return std::nullopt;
    return it->get<T>();
}

Params params_of(const json& j) {
    Params out;
    for (const auto& [name, v] : j.items()) out[name] = value_from_json(v);
    return out;
}

std::vector<Citation> citations_of(const json& j) {
    std::vector<Citation> out;
    for (const auto& c : j)
        out.push_back({c.at("rule").get<std::string>(), c.value("label", ""), c.value("reason", ""),
                       c.value("kind", ""), opt<std::string>(c, "source")});
    return out;
}

Candidate candidate_of(const json& c) {
    Candidate out;
    out.extractor = c.at("extractor").get<std::string>();
    out.score = opt<double>(c, "score");
    out.bonus = c.value("bonus", 0.0);
    if (c.contains("metrics")) out.metrics = c.at("metrics").get<std::map<std::string, double>>();
    out.params = params_of(c.at("params"));
    for (const auto& a : c.value("adjustments", json::array()))
        out.adjustments.push_back({a.at("parameter").get<std::string>(), value_from_json(a.at("from")),
                                   value_from_json(a.at("to")), a.value("factor", 1.0), a.value("clamped", false),
                                   citations_of(a.value("because", json::array()))});
    out.keypoints = opt<int>(c, "keypoints");
    out.extraction_ms = opt<double>(c, "extraction_ms");
    out.evidence = c.value("evidence", json::object());
    return out;
}

OpenCVRecipe recipe_of(const json& o, const Params& params) {
    OpenCVRecipe out{o.at("constructor").get<std::string>(), o.at("norm").get<std::string>(), params, std::nullopt};
    if (o.contains("args")) out.args = params_of(o.at("args"));  // a service before issue 19 sent params only
    if (auto g = o.find("grid"); g != o.end() && g->is_object())
        out.grid = Grid{g->at("cell_size").get<int>(), g->at("keep").get<int>()};
    return out;
}

}  // namespace

Selection Selection::from_json(const json& doc) {
    try {
        Selection s;
        s.extractor = doc.at("extractor").get<std::string>();
        s.params = params_of(doc.at("params"));
        s.opencv = recipe_of(doc.at("opencv"), s.params);
        s.mode = doc.value("mode", "");
        for (const auto& c : doc.value("candidates", json::array())) s.candidates.push_back(candidate_of(c));
        for (const auto& p : doc.value("pruned", json::array()))
            s.pruned.push_back({p.at("extractor").get<std::string>(), citations_of(p.value("because", json::array()))});
        for (const auto& e : doc.value("context", json::array()))
            s.context.push_back({e.at("dimension").get<std::string>(), opt<std::string>(e, "value"), e.value("source", ""),
                                 opt<double>(e, "confidence"), opt<std::string>(e, "evidence")});
        s.weights = doc.value("weights", json::object());
        if (auto b = doc.find("budget"); b != doc.end() && b->is_object())
            s.budget = Budget{b->at("ms").get<double>(), b->value("source", ""), b->value("compute", ""),
                              b->value("factor", 1.0), b->value("width", 0), b->value("height", 0),
                              b->value("size_source", "")};
        s.warnings = doc.value("warnings", std::vector<std::string>{});
        const json& v = doc.at("versions");
        s.versions = {v.value("graph", 0LL), v.value("programs", json::object()), v.value("rules", 0), v.value("model", json())};
        if (auto t = doc.find("timings_ms"); t != doc.end() && t->is_object())
            for (const auto& [k, ms] : t->items())
                if (ms.is_number()) s.timings_ms[k] = ms.get<double>();
        if (auto p = doc.find("session"); p != doc.end() && p->is_object())
            s.session = StreamPosition{p->at("id").get<std::string>(), p->value("frame", 0), p->value("temporal", false)};
        s.raw = doc;
        return s;
    } catch (const json::exception& e) {
        throw ProtocolError(std::string("the answer is not a Selection: ") + e.what());
    }
}

}  // namespace nfex
