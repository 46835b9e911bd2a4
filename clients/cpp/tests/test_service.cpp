// Tests against a real nFEX service: NFEX_TEST_URL (its base URL), NFEX_TEST_FRAME (a real frame,
// e.g. KITTI 01's 000000.png) and NFEX_TEST_TOKEN (a token with the reporter role, for feedback). tests/clients/test_cpp_client.py starts the service over a copy of a
// seeded store and runs these through ctest.
#include "check.hpp"

#include <nfex/nfex.hpp>

#include <opencv2/imgcodecs.hpp>

#include <cstdlib>

namespace {

std::string url() { return std::getenv("NFEX_TEST_URL"); }

std::string reporter_token() {
    const char* token = std::getenv("NFEX_TEST_TOKEN");
    if (token == nullptr) check::fail(__FILE__, __LINE__, "NFEX_TEST_TOKEN is not set");
    return token;
}

cv::Mat frame() {
    const char* path = std::getenv("NFEX_TEST_FRAME");
    if (path == nullptr) check::fail(__FILE__, __LINE__, "NFEX_TEST_FRAME is not set");
    cv::Mat image = cv::imread(path, cv::IMREAD_GRAYSCALE);
    if (image.empty()) check::fail(__FILE__, __LINE__, std::string("cannot read ") + path);
    return image;
}

std::size_t keypoints_on(const nfex::Selection& s, const cv::Mat& image) {
    std::vector<cv::KeyPoint> kps;
    cv::Mat d;
    nfex::make_feature2d(s)->detectAndCompute(image, cv::noArray(), kps, d);
    return kps.size();
}

}  // namespace

TEST(service, ready_reports_the_graph_version) {
    nfex::Client nfex(url());
    CHECK(nfex.ready().at("graph_version").get<long long>() >= 1);
}

TEST(service, a_context_alone_gets_a_prior_selection_with_reasons) {
    nfex::Client nfex(url());
    nfex::Selection s = nfex.select({{"agent", "car"}, {"motion", "fast"}});
    CHECK(s.mode == "prior" || s.mode == "selectornet");  // no frame: no F_metrics
    CHECK(!s.extractor.empty() && !s.candidates.empty());
    CHECK_EQ(s.candidates.front().extractor, s.extractor);
    CHECK(s.versions.graph >= 1);
    CHECK(!s.opencv.constructor.empty() && !s.opencv.args.empty());
    for (const auto& p : s.pruned) CHECK(!p.because.empty() && !p.because.front().rule.empty());
    CHECK(keypoints_on(s, frame()) > 100);
}

TEST(service, a_frame_is_scored_and_its_extractor_finds_keypoints) {
    nfex::Client nfex(url());
    nfex::Selection s = nfex.select(frame(), {{"agent", "car"}, {"scene", "outdoor"}});
    CHECK(s.mode != "prior");
    bool estimated = false;
    for (const auto& e : s.context) estimated = estimated || e.source == "estimated";
    CHECK(estimated);  // light, texture… filled from the frame
    // α* was extracted on the scoring copy (its metrics), or SelectorNet's bounds settled it without extraction
    const nfex::Candidate& best = s.candidates.front();
    CHECK(!best.metrics.empty() || best.evidence.value("not_scored", "").find("whatever the unmeasured metrics") != std::string::npos);
    CHECK(best.score.has_value());
    CHECK(s.timings_ms.count("total") == 1);
    CHECK(keypoints_on(s, frame()) > 100);
    CHECK(nfex::make_matcher(s) != nullptr);
}

TEST(service, an_unknown_condition_value_is_unprocessable_with_the_allowed_values) {
    nfex::Client nfex(url());
    try {
        nfex.select(frame(), {{"agent", "submarine"}});
        check::fail(__FILE__, __LINE__, "no Unprocessable");
    } catch (const nfex::Unprocessable& e) {
        CHECK_EQ(e.slug(), "unknown-name");
        CHECK(e.detail().find("submarine") != std::string::npos);
        auto allowed = e.allowed();
        CHECK(std::find(allowed.begin(), allowed.end(), "car") != allowed.end());
    }
}

TEST(service, a_session_carries_the_previous_frame_and_takes_feedback) {
    nfex::Client nfex(url(), reporter_token());
    nfex::Session session = nfex.open_session({{"agent", "car"}}, "cpp-test");
    cv::Mat image = frame();
    nfex::Selection first = session.frame(image);
    CHECK(first.session && first.session->id == session.id() && first.session->frame == 1 && !first.session->temporal);
    nfex::Selection second = session.frame(image, {{"scene", "outdoor"}});
    CHECK(second.session->frame == 2 && second.session->temporal);
    CHECK(session.last() && session.last()->session->frame == 2);

    nfex::Feedback fb = nfex::Feedback::of(second);
    fb.sequence = "cpp-client/test";
    fb.window_start = 0;
    fb.window_end = 2;
    fb.mean_matches = 321.5;
    nfex::WriteResult r = session.feedback(fb);
    CHECK(r.changed && r.version > first.versions.graph);
    CHECK(r.iri && r.iri->rfind("https://w3id.org/nfex#measurement_", 0) == 0);

    session.close();
    session.close();  // again: nothing to do
    CHECK_THROWS(session.frame(image), nfex::Error);
}

TEST(service, feedback_without_a_token_is_unauthorized) {
    nfex::Client nfex(url());  // selecting needs no token; reporting needs the reporter role
    nfex::Selection s = nfex.select({{"agent", "car"}});
    nfex::Feedback fb = nfex::Feedback::of(s);
    fb.sequence = "cpp-client/anonymous";
    CHECK_THROWS(nfex.feedback(fb), nfex::Unauthorized);
}

TEST(service, sparql_answers_json_results_and_bad_queries_are_bad_requests) {
    nfex::Client nfex(url());
    auto doc = nfex.sparql("SELECT ?x WHERE { ?x a nfex:FeatureExtractor }");
    CHECK(doc.at("results").at("bindings").size() >= 5);
    CHECK_THROWS(nfex.sparql("SELECT nonsense"), nfex::BadRequest);
}

TEST(service, a_frame_can_go_as_jpeg) {
    nfex::Options o;
    o.frame_format = nfex::FrameFormat::jpeg;
    nfex::Client nfex(url(), "", o);
    CHECK(!nfex.select(frame(), {{"agent", "car"}}).extractor.empty());
}
