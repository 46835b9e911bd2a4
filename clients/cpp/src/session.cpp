#include "nfex/session.hpp"

#include "nfex/client.hpp"
#include "nfex/errors.hpp"
#include "transport.hpp"

#include <utility>

namespace nfex {

Session::Session(std::shared_ptr<detail::Transport> http, std::string id) : http_(std::move(http)), id_(std::move(id)) {}

Session::~Session() {
    try {
        close();
    } catch (const std::exception&) {  // a destructor must not throw; the service expires idle streams
    }
}

Session::Session(Session&& other) noexcept
    : http_(std::move(other.http_)), id_(std::move(other.id_)), last_(std::move(other.last_)) {}

Session& Session::operator=(Session&& other) noexcept {
    if (this != &other) {
        try {
            close();
        } catch (const std::exception&) {
        }
        http_ = std::move(other.http_);
        id_ = std::move(other.id_);
        last_ = std::move(other.last_);
    }
    return *this;
}

Selection Session::frame(const cv::Mat& image, const Context& context) {
    if (!http_) throw Error("the session " + id_ + " is closed");
    detail::Request r{"POST", "/v1/sessions/" + id_ + "/frames"};
    r.parts = {detail::frame_part(image, http_->options().frame_format)};
    if (!context.empty()) r.parts.push_back({"context", nlohmann::json(context).dump(), "", ""});
    last_ = Selection::from_json(http_->call(r));
    return *last_;
}

WriteResult Session::feedback(Feedback feedback) {
    if (!http_) throw Error("the session " + id_ + " is closed");
    feedback.session_id = id_;
    return detail::send_feedback(*http_, feedback);
}

void Session::close() {
    if (!http_) return;
    detail::Request r{"DELETE", "/v1/sessions/" + id_};
    r.idempotent = true;
    auto http = std::move(http_);  // closed from here on, whatever the answer
    detail::Response answer = http->send(r);
    if (answer.status >= 400 && answer.status != 404) throw_problem(answer.status, answer.body);
}

}  // namespace nfex
