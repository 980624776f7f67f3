/* Attribute text: EXR attribute strings are read whole
 * or refused, and text past an attr_list's storage says it was cut. */
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "formats/exr.h"
#include "harness.h"
#include "io/output.h"

/* A string attribute longer than the reader's buffer was cut to fit, so
 * two different long values could read back equal. */
TEST(exr_string_attributes_longer_than_the_buffer_are_refused)
{
    char path[128], value[301], small[64], big[512];
    snprintf(path, sizeof path, "/tmp/refrender-attr-text-%d.exr", (int)getpid());
    memset(value, 'v', 300), value[300] = 0;
    exr_string_attr attrs[1] = {{"refrender:command", value, RR_ATTR_TEXT}};
    float px[4] = {0};
    rr_error e = {{0}};
    CHECK(exr_write_rgba(path, 1, 1, px, attrs, 1, &e) == 0);
    CHECK(exr_read_string_attr(path, "refrender:command", small, sizeof small, &e) == -1);
    CHECK(strstr(e.msg, "attribute 'refrender:command' is 300 characters long: at most 63 are read") != NULL);
    CHECK(exr_read_string_attr(path, "refrender:command", big, sizeof big, &e) == 0 && !strcmp(big, value));
    CHECK(exr_read_string_attr(path, "refrender:nothing", big, sizeof big, &e) == 1); /* absent */
    unlink(path);
}

/* attrs_set cut a value past ATTR_TEXT_MAX without a word; the identity
 * texts that can be that long go by their hash (render_attrs.c), and any
 * other value now ends saying it was cut and from how long. */
TEST(attribute_text_past_its_storage_says_it_was_cut)
{
    attr_list *a = calloc(1, sizeof *a);
    char *text = malloc(5001);
    memset(text, 't', 5000), text[5000] = 0;
    attrs_set(a, "refrender:command", "%s", text);
    const char *v = attrs_get(a, "refrender:command");
    const char *tail = " ... (cut: 5000 characters)";
    CHECK(v && strlen(v) < ATTR_TEXT_MAX && strlen(v) > strlen(tail));
    CHECK(v && !strcmp(v + strlen(v) - strlen(tail), tail));
    attrs_set(a, "refrender:scene", "%s", "short");
    CHECK(!strcmp(attrs_get(a, "refrender:scene"), "short"));
    free(text), free(a);
}
