// nFEX C++ client: the HTTP client (libcurl) for a running nFEX service (docs/service.md).
//
//   nfex::Client nfex("http://127.0.0.1:8000");
//   nfex::Selection sel = nfex.select(frame, {{"agent", "car"}, {"scene", "outdoor"}});
//   cv::Ptr<cv::Feature2D> extractor = nfex::make_feature2d(sel);
//
// Every error answer (RFC 9457 problem+json) is thrown as a ProblemError subclass (errors.hpp); an
// unreachable or silent service as TransportError after the configured retries.
#pragma once

#include "nfex/context.hpp"
#include "nfex/opencv.hpp"
#include "nfex/selection.hpp"
#include "nfex/session.hpp"

#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>

#include <chrono>
#include <memory>
#include <optional>
#include <string>

namespace nfex {

namespace detail {
class Transport;
}

struct Options {
    std::chrono::milliseconds connect_timeout{5000};
    std::chrono::milliseconds timeout{30000};  // one attempt, connecting included
    /// Extra attempts after a failure that a repeat cannot make worse: a refused connection (any
    /// request), or — for requests that change nothing (select, SPARQL, reads) — a timeout, a broken
    /// answer, 502/504, or a 503 that is not a query's own time or size limit. 429 is retried for all.
    int retries = 2;
    std::chrono::milliseconds backoff{200};  // the first wait; doubles per retry
    std::chrono::milliseconds max_backoff{5000};
    FrameFormat frame_format = FrameFormat::png;  // lossless by default
};

/// What a write answered: the graph version after it (the new ETag) and what changed.
struct WriteResult {
    long long version = 0;
    bool changed = false;
    int added = 0, removed = 0;
    std::optional<std::string> iri;  // e.g. the new Measurement's
};

/// A client's measured result with a selection over a window of frames (POST /v1/feedback; schema
/// FeedbackRequest). It becomes a SHACL-checked nfex:Measurement with provenance; at least one result
/// (ate_rmse … mean_matches) must be set.
struct Feedback {
    std::string extractor;
    Params params;
    Context context;
    std::optional<std::string> session_id;  // the session's context and client fill the gaps
    std::string sequence = "client-stream";
    std::optional<std::string> dataset, client;
    std::optional<int> window_start, window_end, frames;
    std::optional<double> ate_rmse, rpe_rmse;
    std::optional<int> tracking_lost;
    std::optional<bool> tracking_failed;
    std::optional<double> mean_inliers, mean_matches, mean_keypoints, extraction_ms, matching_ms;
    std::optional<int> width, height;

    /// α and Θ′ of a selection (and its session, for a session frame).
    static Feedback of(const Selection& selection);
    nlohmann::json to_json() const;
};

class Client {
public:
    /// `url`: the service's base URL; `token`: a bearer token (reads need none; feedback needs the reporter role).
    explicit Client(std::string url, std::string token = "", Options options = {});
    ~Client();
    Client(Client&&) noexcept;
    Client& operator=(Client&&) noexcept;

    /// α, Θ′ and why for a context alone (rules and measurements; mode "prior").
    Selection select(const Context& context);
    /// The same for a frame (8- or 16-bit, grey or BGR), sent as PNG unless options say JPEG.
    Selection select(const cv::Mat& frame, const Context& context);
    /// A frame stream: the service keeps the previous frame for temporal metrics and motion.
    Session open_session(const Context& context = {}, const std::string& client_name = "");
    WriteResult feedback(const Feedback& feedback);
    /// A SPARQL 1.1 query (read-only); the application/sparql-results+json document.
    nlohmann::json sparql(const std::string& query);
    /// GET /readyz: the graph version, the rule table, … (ServiceUnavailable until the service is ready).
    nlohmann::json ready();

    const Options& options() const;

private:
    std::shared_ptr<detail::Transport> http_;
};

}  // namespace nfex
