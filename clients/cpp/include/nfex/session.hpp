// nFEX C++ client: a frame stream (POST /v1/sessions, then POST /v1/sessions/{id}/frames per frame).
//
// The service keeps what it computed for the previous frame (its scoring image and every candidate's
// features), so temporal metrics and motion estimation work from the second frame on
// (Selection::session->temporal). A Session is move-only and closes its stream when destroyed.
//
// DESIGN.md's verification step will add one call here: after frame(), the client matches the first
// proposal against the previous frame and reports the pair's evidence; the service answers accept, the
// next proposal, or the motion prior. last() keeps the selection that such a report refers to.
#pragma once

#include "nfex/context.hpp"
#include "nfex/selection.hpp"

#include <opencv2/core.hpp>

#include <memory>
#include <optional>
#include <string>

namespace nfex {

namespace detail {
class Transport;
}
struct Feedback;
struct WriteResult;

class Session {
public:
    Session(std::shared_ptr<detail::Transport> http, std::string id);
    ~Session();  // closes the stream; never throws
    Session(Session&&) noexcept;
    Session& operator=(Session&&) noexcept;
    Session(const Session&) = delete;
    Session& operator=(const Session&) = delete;

    const std::string& id() const noexcept { return id_; }
    /// The next frame; `context` overrides the session's context for this frame only.
    Selection frame(const cv::Mat& image, const Context& context = {});
    /// The last frame's selection, if any.
    const std::optional<Selection>& last() const noexcept { return last_; }
    /// Feedback for this stream: the session's context and client fill what `feedback` leaves out.
    WriteResult feedback(Feedback feedback);
    /// DELETE the stream (again: no-op). Throws on an error answer other than 404.
    void close();

private:
    std::shared_ptr<detail::Transport> http_;
    std::string id_;
    std::optional<Selection> last_;
};

}  // namespace nfex
