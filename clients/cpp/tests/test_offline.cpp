// Tests that need no nFEX service: context parsing, the grid spread, building every extractor, problem
// mapping, and the retry policy against loopback sockets the test controls (a closed port, a listener
// that never answers, a responder with canned status lines).
#include "check.hpp"

#include <nfex/nfex.hpp>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <atomic>
#include <cstdlib>
#include <set>
#include <thread>

using namespace std::chrono_literals;

namespace {

cv::Mat textured_image() {  // corners and blobs at many scales; a fixed seed
    cv::Mat image(240, 320, CV_8U);
    cv::RNG rng(7);
    rng.fill(image, cv::RNG::UNIFORM, 0, 256);
    cv::GaussianBlur(image, image, cv::Size(0, 0), 2.0);
    for (int i = 0; i < 40; ++i)
        cv::rectangle(image, cv::Rect(rng.uniform(0, 300), rng.uniform(0, 220), rng.uniform(5, 40), rng.uniform(5, 40)),
                      cv::Scalar(rng.uniform(0, 256)), cv::FILLED);
    return image;
}

nfex::OpenCVRecipe recipe(const std::string& constructor, nfex::Params args, std::optional<nfex::Grid> grid = std::nullopt) {
    return {constructor, "NORM_HAMMING", std::move(args), grid};
}

std::size_t keypoints_of(const cv::Ptr<cv::Feature2D>& f, const cv::Mat& image, cv::Mat* descriptors = nullptr) {
    std::vector<cv::KeyPoint> kps;
    cv::Mat d;
    f->detectAndCompute(image, cv::noArray(), kps, d);
    if (descriptors) *descriptors = d;
    return kps.size();
}

/// A loopback socket: listening (and, with answers, serving them one per connection in order) or closed.
struct Loopback {
    int fd = -1, port = 0;
    std::vector<std::string> answers;
    std::atomic<int> requests{0};
    std::string last_request;
    std::thread server;

    explicit Loopback(bool listen_ = true, std::vector<std::string> canned = {}) : answers(std::move(canned)) {
        fd = ::socket(AF_INET, SOCK_STREAM, 0);
        sockaddr_in addr{};
        addr.sin_family = AF_INET;
        addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
        ::bind(fd, reinterpret_cast<sockaddr*>(&addr), sizeof addr);
        socklen_t len = sizeof addr;
        ::getsockname(fd, reinterpret_cast<sockaddr*>(&addr), &len);
        port = ntohs(addr.sin_port);
        if (!listen_) {  // a port nobody listens on
            ::close(fd);
            fd = -1;
            return;
        }
        ::listen(fd, 16);
        if (!answers.empty()) server = std::thread([this] { serve(); });
    }
    ~Loopback() {
        if (server.joinable()) server.join();
        if (fd >= 0) ::close(fd);
    }
    std::string url() const { return "http://127.0.0.1:" + std::to_string(port); }

    void serve() {
        for (const std::string& answer : answers) {
            int c = ::accept(fd, nullptr, nullptr);
            if (c < 0) return;
            std::string request;
            char buf[4096];
            while (request.find("\r\n\r\n") == std::string::npos) {
                ssize_t n = ::recv(c, buf, sizeof buf, 0);
                if (n <= 0) break;
                request.append(buf, static_cast<std::size_t>(n));
            }
            last_request = request;
            ++requests;
            ::send(c, answer.data(), answer.size(), 0);
            ::close(c);
        }
    }
};

std::string http_answer(int status, const std::string& body, const std::string& type = "application/problem+json") {
    return "HTTP/1.1 " + std::to_string(status) + " X\r\nContent-Type: " + type + "\r\nContent-Length: " +
           std::to_string(body.size()) + "\r\nConnection: close\r\n\r\n" + body;
}

nfex::Options quick(int retries) {
    nfex::Options o;
    o.retries = retries;
    o.backoff = 5ms;
    o.timeout = 400ms;
    o.connect_timeout = 400ms;
    return o;
}

}  // namespace

TEST(offline, context_is_parsed_from_name_value_items) {
    nfex::Context c = nfex::parse_context(" agent=car, scene = outdoor,,budget_ms=20 ");
    CHECK_EQ(c.size(), 3u);
    CHECK_EQ(c["agent"], "car");
    CHECK_EQ(c["scene"], "outdoor");
    CHECK_EQ(c["budget_ms"], "20");
    CHECK(nfex::parse_context("").empty());
    CHECK_THROWS(nfex::parse_context("agent"), std::invalid_argument);
    CHECK_THROWS(nfex::parse_context("=car"), std::invalid_argument);
    CHECK_THROWS(nfex::parse_context("agent="), std::invalid_argument);
}

TEST(offline, grid_spread_takes_each_cells_best_before_any_seconds) {
    auto kp = [](float x, float y, float r) { return cv::KeyPoint(x, y, 7.f, -1.f, r); };
    // cell 10 px: two in cell (0,0), one each in cells (1,0) and (2,0); two equal responses in (0,1)
    std::vector<cv::KeyPoint> in = {kp(1, 1, .9f), kp(2, 2, .8f), kp(15, 1, .1f), kp(25, 1, .5f), kp(3, 12, .3f), kp(4, 13, .3f)};
    auto out = nfex::spread_keypoints(in, 10, 0);
    std::vector<float> xs;
    for (const auto& k : out) xs.push_back(k.pt.x);
    // rank 0 by response: (1,1) .9, (25,1) .5, (3,12) .3 [input order before (4,13)], (15,1) .1; then rank 1
    CHECK((xs == std::vector<float>{1, 25, 3, 15, 2, 4}));
    auto kept = nfex::spread_keypoints(in, 10, 3);
    CHECK_EQ(kept.size(), 3u);
    CHECK_EQ(kept[2].pt.x, 3.f);
    CHECK(nfex::spread_keypoints({}, 10, 5).empty());
    CHECK_THROWS(nfex::spread_keypoints(in, 0, 5), std::invalid_argument);
}

TEST(offline, every_constructor_of_the_graph_builds_and_detects) {
    cv::Mat image = textured_image();
    cv::Mat d;
    CHECK(keypoints_of(nfex::make_feature2d(recipe("ORB_create", {{"nfeatures", std::int64_t(300)}, {"scaleFactor", 1.2}})), image, &d) > 50);
    CHECK_EQ(d.type(), CV_8U);
    CHECK(keypoints_of(nfex::make_feature2d(recipe("SIFT_create", {{"nfeatures", std::int64_t(0)}, {"sigma", 1.6},
                                                                  {"enable_precise_upscale", false}})), image, &d) > 20);
    CHECK_EQ(d.type(), CV_32F);
    CHECK(keypoints_of(nfex::make_feature2d(recipe("xfeatures2d.AKAZE_create", {{"threshold", 0.0005}, {"max_points", std::int64_t(-1)}})), image) > 10);
    CHECK(keypoints_of(nfex::make_feature2d(recipe("xfeatures2d.BRISK_create", {{"thresh", std::int64_t(20)}, {"patternScale", 1.0}})), image) > 10);
    CHECK(keypoints_of(nfex::make_feature2d(recipe("KAZE_create", {{"extended", false}})), image) > 10);
}

TEST(offline, a_grid_recipe_spreads_the_oversampled_detections) {
    cv::Mat image = textured_image();
    nfex::Params args = {{"nfeatures", std::int64_t(600)}, {"fastThreshold", std::int64_t(10)}};
    auto grid = nfex::make_feature2d(recipe("ORB_create", args, nfex::Grid{48, 200}));
    CHECK(dynamic_cast<nfex::GridSpread*>(grid.get()) != nullptr);
    std::vector<cv::KeyPoint> spread, plain;
    cv::Mat descriptors;
    grid->detectAndCompute(image, cv::noArray(), spread, descriptors);
    CHECK(spread.size() <= 200 && spread.size() > 150);
    CHECK_EQ(descriptors.rows, static_cast<int>(spread.size()));
    cv::ORB::create(200, 1.2f, 8, 31, 0, 2, cv::ORB::HARRIS_SCORE, 31, 10)->detect(image, plain);
    auto cells = [](const std::vector<cv::KeyPoint>& kps) {
        std::set<std::pair<int, int>> c;
        for (const auto& k : kps) c.insert({int(k.pt.x) / 48, int(k.pt.y) / 48});
        return c.size();
    };
    CHECK(cells(spread) >= cells(plain));  // the point of the grid: at least as many cells covered
}

TEST(offline, what_cannot_be_built_is_an_extractor_error) {
    CHECK_THROWS(nfex::make_feature2d(recipe("SURF_create", {})), nfex::ExtractorError);
    CHECK_THROWS(nfex::make_feature2d(recipe("ORB_create", {{"gridCellSize", std::int64_t(48)}})), nfex::ExtractorError);
    CHECK_THROWS(nfex::make_feature2d(recipe("ORB_create", {{"nfeatures", true}})), nfex::ExtractorError);
    CHECK_THROWS(nfex::make_feature2d(recipe("ORB_create", {{"nfeatures", 10.5}})), nfex::ExtractorError);
    CHECK_THROWS(nfex::make_feature2d(recipe("xfeatures2d.AKAZE_create", {{"max_points", std::int64_t(100)}})), nfex::ExtractorError);
    CHECK_THROWS(nfex::norm_type("NORM_NONE"), nfex::ExtractorError);
    CHECK_EQ(nfex::norm_type("NORM_HAMMING2"), static_cast<int>(cv::NORM_HAMMING2));
}

TEST(offline, problems_become_typed_exceptions) {
    try {
        nfex::throw_problem(422, R"({"type": "https://w3id.org/nfex/problems/unknown-name", "title": "Unknown name",
            "status": 422, "detail": "unknown agent 'submarine'", "allowed": ["car", "drone"]})");
    } catch (const nfex::Unprocessable& e) {
        CHECK_EQ(e.slug(), "unknown-name");
        CHECK_EQ(e.title(), "Unknown name");
        CHECK_EQ(e.detail(), "unknown agent 'submarine'");
        CHECK_EQ(e.status(), 422);
        CHECK((e.allowed() == std::vector<std::string>{"car", "drone"}));
    }
    try {
        nfex::throw_problem(412, R"({"type": "t/precondition-failed", "title": "T", "detail": "D", "current_version": 7})");
    } catch (const nfex::Conflict& e) {  // 412 is a Conflict
        CHECK_EQ(dynamic_cast<const nfex::PreconditionFailed&>(e).current_version(), 7);
    }
    try {
        nfex::throw_problem(502, "<html>bad gateway</html>");
    } catch (const nfex::ServerError& e) {
        CHECK_EQ(e.detail(), "<html>bad gateway</html>");
        CHECK_EQ(e.title(), "Bad gateway");
    }
    CHECK_THROWS(nfex::throw_problem(418, "{}"), nfex::ProblemError);
    CHECK_THROWS(nfex::throw_problem(503, R"({"title": "x", "limit": "time"})"), nfex::ServiceUnavailable);
    CHECK_THROWS(nfex::Selection::from_json({{"params", nlohmann::json::object()}}), nfex::ProtocolError);
}

TEST(offline, a_refused_connection_is_retried_with_backoff_then_a_transport_error) {
    Loopback closed(false);
    nfex::Client nfex(closed.url(), "", quick(2));
    try {
        nfex.open_session({});  // even a request that creates something: nothing reached the service
        check::fail(__FILE__, __LINE__, "no TransportError");
    } catch (const nfex::TransportError& e) {
        CHECK(e.kind() == nfex::TransportError::Kind::connect);
        CHECK_EQ(e.attempts(), 3);
    }
}

TEST(offline, a_timeout_is_retried_only_for_requests_that_change_nothing) {
    Loopback silent;  // accepts connections (the backlog) and never answers
    nfex::Client nfex(silent.url(), "", quick(1));
    try {
        nfex.select({{"agent", "car"}});
        check::fail(__FILE__, __LINE__, "no TransportError");
    } catch (const nfex::TransportError& e) {
        CHECK(e.kind() == nfex::TransportError::Kind::timeout);
        CHECK_EQ(e.attempts(), 2);
    }
    try {
        nfex.open_session({});
        check::fail(__FILE__, __LINE__, "no TransportError");
    } catch (const nfex::TransportError& e) {
        CHECK(e.kind() == nfex::TransportError::Kind::timeout);
        CHECK_EQ(e.attempts(), 1);
    }
}

TEST(offline, error_answers_are_retried_by_what_they_mean) {
    const std::string unavailable = R"({"type": "x/store-unavailable", "title": "Store unavailable", "detail": "d"})";
    const std::string over_time = R"({"type": "x/query-limit", "title": "Query limit", "detail": "d", "limit": "time"})";
    {
        Loopback s(true, {http_answer(503, unavailable), http_answer(503, unavailable), http_answer(503, unavailable)});
        nfex::Client nfex(s.url(), "t0k", quick(2));
        CHECK_THROWS(nfex.select({}), nfex::ServiceUnavailable);
        CHECK_EQ(s.requests.load(), 3);
        CHECK(s.last_request.find("Authorization: Bearer t0k") != std::string::npos);
    }
    {
        Loopback s(true, {http_answer(503, over_time)});
        nfex::Client nfex(s.url(), "", quick(2));
        CHECK_THROWS(nfex.sparql("SELECT * WHERE { ?s ?p ?o }"), nfex::ServiceUnavailable);
        CHECK_EQ(s.requests.load(), 1);  // the same query would hit the same limit
    }
    {
        Loopback s(true, {http_answer(429, R"({"title": "Too many sessions", "detail": "d"})"), http_answer(201, R"({"id": "s1"})", "application/json"),
                          http_answer(204, "")});  // the session's close
        nfex::Client nfex(s.url(), "", quick(2));
        nfex::Session session = nfex.open_session({});
        CHECK_EQ(session.id(), "s1");
        CHECK_EQ(s.requests.load(), 2);
        session.close();
        CHECK_EQ(s.requests.load(), 3);
        CHECK(s.last_request.rfind("DELETE /v1/sessions/s1 ", 0) == 0);
    }
    {
        Loopback s(true, {http_answer(502, "bad gateway", "text/plain")});
        nfex::Client nfex(s.url(), "", quick(2));
        CHECK_THROWS(nfex.feedback(nfex::Feedback{}), nfex::ServerError);  // a write may have landed: not repeated
        CHECK_EQ(s.requests.load(), 1);
    }
}
