// Private: one libcurl easy handle per Client (connections kept alive), shared with its Sessions and
// used under a mutex; retries with exponential backoff as Options says.
#pragma once

#include "nfex/client.hpp"

#include <curl/curl.h>
#include <nlohmann/json.hpp>

#include <mutex>
#include <string>
#include <utility>
#include <vector>

namespace nfex::detail {

struct Part {
    std::string name, data, filename, content_type;  // a file part when filename is set
};

struct Request {
    Request(std::string method_, std::string path_, std::string body_ = {}, std::string content_type_ = {})
        : method(std::move(method_)), path(std::move(path_)), body(std::move(body_)), content_type(std::move(content_type_)) {}

    std::string method;
    std::string path;
    std::string body, content_type;  // a plain body…
    std::vector<Part> parts;         // …or multipart/form-data
    std::string accept = "application/json";
    bool idempotent = false;  // changes nothing on the service: safe to send again after a timeout
};

struct Response {
    int status = 0;
    std::string body;
};

class Transport {
public:
    Transport(std::string url, std::string token, Options options);
    ~Transport();
    Transport(const Transport&) = delete;
    Transport& operator=(const Transport&) = delete;

    /// The answer of any status; TransportError when none came after the retries.
    Response send(const Request& request);
    /// send(), then the problem as an exception for a status >= 400, else the body as JSON.
    nlohmann::json call(const Request& request);

    const Options& options() const { return options_; }

private:
    struct Attempt;
    Attempt perform(const Request& request);

    std::string url_, token_;
    Options options_;
    CURL* curl_;
    std::mutex mutex_;
};

/// The multipart frame part, encoded as the options say.
Part frame_part(const cv::Mat& frame, FrameFormat format);
/// POST /v1/feedback.
WriteResult send_feedback(Transport& http, const Feedback& feedback);

}  // namespace nfex::detail
