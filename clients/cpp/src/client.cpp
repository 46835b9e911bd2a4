#include "nfex/client.hpp"

#include "nfex/errors.hpp"
#include "nfex/session.hpp"
#include "transport.hpp"

#include <utility>

namespace nfex {

using nlohmann::json;

namespace detail {

Part frame_part(const cv::Mat& frame, FrameFormat format) {
    std::vector<unsigned char> bytes = encode_frame(frame, format);
    bool png = format == FrameFormat::png;
    return {"frame", std::string(bytes.begin(), bytes.end()), png ? "frame.png" : "frame.jpg", png ? "image/png" : "image/jpeg"};
}

WriteResult send_feedback(Transport& http, const Feedback& feedback) {
    Request r{"POST", "/v1/feedback", feedback.to_json().dump(), "application/json"};
    json doc = http.call(r);
    try {
        WriteResult out{doc.at("version").get<long long>(), doc.at("changed").get<bool>(), doc.value("added", 0),
                        doc.value("removed", 0), std::nullopt};
        if (doc.contains("iri") && doc["iri"].is_string()) out.iri = doc["iri"].get<std::string>();
        return out;
    } catch (const json::exception& e) {
        throw ProtocolError(std::string("the feedback answer is not a write result: ") + e.what());
    }
}

}  // namespace detail

Feedback Feedback::of(const Selection& selection) {
    Feedback f;
    f.extractor = selection.extractor;
    f.params = selection.params;
    if (selection.session) f.session_id = selection.session->id;
    return f;
}

json Feedback::to_json() const {
    json doc = {{"extractor", extractor}, {"params", nfex::to_json(params)}, {"context", context}, {"sequence", sequence}};
    auto put = [&doc](const char* key, const auto& value) {
        if (value) doc[key] = *value;
    };
    put("session_id", session_id);
    put("dataset", dataset);
    put("client", client);
    put("window_start", window_start);
    put("window_end", window_end);
    put("frames", frames);
    put("ate_rmse", ate_rmse);
    put("rpe_rmse", rpe_rmse);
    put("tracking_lost", tracking_lost);
    put("tracking_failed", tracking_failed);
    put("mean_inliers", mean_inliers);
    put("mean_matches", mean_matches);
    put("mean_keypoints", mean_keypoints);
    put("extraction_ms", extraction_ms);
    put("matching_ms", matching_ms);
    put("width", width);
    put("height", height);
    return doc;
}

Client::Client(std::string url, std::string token, Options options)
    : http_(std::make_shared<detail::Transport>(std::move(url), std::move(token), options)) {}
Client::~Client() = default;
Client::Client(Client&&) noexcept = default;
Client& Client::operator=(Client&&) noexcept = default;

const Options& Client::options() const { return http_->options(); }

Selection Client::select(const Context& context) {
    detail::Request r{"POST", "/v1/select", json{{"context", context}}.dump(), "application/json"};
    r.idempotent = true;
    return Selection::from_json(http_->call(r));
}

Selection Client::select(const cv::Mat& frame, const Context& context) {
    detail::Request r{"POST", "/v1/select"};
    r.parts = {detail::frame_part(frame, http_->options().frame_format), {"context", json(context).dump(), "", ""}};
    r.idempotent = true;
    return Selection::from_json(http_->call(r));
}

Session Client::open_session(const Context& context, const std::string& client_name) {
    json body = {{"context", context}, {"client", client_name.empty() ? json() : json(client_name)}};
    json doc = http_->call(detail::Request("POST", "/v1/sessions", body.dump(), "application/json"));
    if (!doc.is_object() || !doc.contains("id") || !doc["id"].is_string())
        throw ProtocolError("the new session's answer has no id: " + doc.dump());
    return Session(http_, doc["id"].get<std::string>());
}

WriteResult Client::feedback(const Feedback& feedback) { return detail::send_feedback(*http_, feedback); }

json Client::sparql(const std::string& query) {
    detail::Request r{"POST", "/sparql", query, "application/sparql-query"};
    r.accept = "application/sparql-results+json";
    r.idempotent = true;
    return http_->call(r);
}

json Client::ready() {
    detail::Request r{"GET", "/readyz"};
    r.idempotent = true;
    return http_->call(r);
}

}  // namespace nfex
